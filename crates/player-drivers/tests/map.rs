//! End-to-end: `map` devices served by the `mapfile` driver and by the `stage` driver, read
//! over TCP with the Rust client's `MapProxy` the way libplayerc reads them (GET_INFO, then
//! 640 × 640 tiles whose cells travel zlib-compressed).

use std::net::TcpListener;
use std::path::{Path, PathBuf};

use image::{GrayImage, Luma};
use player_client::{ClientError, MapProxy, OccupancyMap, PlayerClient};
use player_server::stage::{self, StageOptions};
use player_server::{DriverRegistry, Pace, Server, ServerConfig, ServerHandle};
use worldfile::{CfgFile, LoadOptions};

/// A fresh folder for this test's files.
fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("player-drivers-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The workspace root.
fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .and_then(Path::parent)
        .unwrap()
}

/// Serves `cfg` (every device on one free port) with this crate's drivers and `stage`.
fn serve(cfg: &Path) -> (ServerHandle, u16) {
    let cfg = CfgFile::load(cfg, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let blocks = player_server::cfg::driver_blocks(&cfg, port).unwrap();
    let mut registry = DriverRegistry::new();
    player_drivers::register_all(&mut registry);
    stage::register(
        &mut registry,
        StageOptions {
            seed: 1,
            usegui: Some(false),
        },
    );
    let mut server = Server::new(ServerConfig {
        pace: Pace::RealTime { speedup: 1.0 },
        ..ServerConfig::default()
    });
    for b in &blocks {
        server
            .add_block(b, &mut registry)
            .unwrap_or_else(|e| panic!("{e}"));
    }
    server.use_listener(u32::from(port), listener);
    (server.start().unwrap(), port)
}

/// The grey level of pixel (x, y) of the test image: black, mid-grey and white squares.
fn shade(x: u32, y: u32) -> u8 {
    match (x / 10 + y / 7) % 3 {
        0 => 0,
        1 => 128,
        _ => 255,
    }
}

#[test]
fn mapfile_and_stage_maps_read_through_the_client() {
    let dir = scratch("map");
    // 700 × 660 pixels: four tiles, the right and top ones partial.
    let (w, h) = (700u32, 660u32);
    GrayImage::from_fn(w, h, |x, y| Luma([shade(x, y)]))
        .save(dir.join("squares.png"))
        .unwrap();
    let cave = root().join("bitmaps/bigbob_cave.png");
    std::fs::write(
        dir.join("maps.world"),
        format!(
            "resolution 0.02\n\
             model ( name \"lshape\" size [2 2 1] pose [5 5 0 0]\n\
               block ( points 4 point[0] [0 0] point[1] [1 0] point[2] [1 4] point[3] [0 4] z [0 1] )\n\
               block ( points 4 point[0] [1 0] point[1] [4 0] point[2] [4 1] point[3] [1 1] z [0 1] )\n\
             )\n\
             model ( name \"cave\" size [16 16 1.5] bitmap \"{}\" )\n",
            cave.display()
        ),
    )
    .unwrap();
    std::fs::write(
        dir.join("maps.cfg"),
        "driver ( name \"mapfile\" provides [\"map:0\"] filename \"squares.png\" resolution 0.05 )\n\
         driver ( name \"mapfile\" provides [\"map:3\"] filename \"squares.png\" resolution 0.05 \
                  negate 1 origin [1 2 45] )\n\
         driver ( name \"mapfile\" provides [\"map:4\"] filename \"../../bitmaps/bigbob_cave.png\" \
                  resolution 0.125 origin [-8 -8 0] )\n\
         driver ( name \"stage\" provides [\"simulation:0\"] worldfile \"maps.world\" )\n\
         driver ( name \"stage\" provides [\"map:1\"] model \"lshape\" )\n\
         driver ( name \"stage\" provides [\"map:2\"] model \"cave\" )\n"
            .replace("../../bitmaps/bigbob_cave.png", &cave.display().to_string())
            .as_str(),
    )
    .unwrap();
    let (server, port) = serve(&dir.join("maps.cfg"));
    let client = PlayerClient::connect("localhost", port).unwrap();

    // mapfile: the picture, the top image row as the highest map row, centred on (0, 0).
    let squares = MapProxy::new(&client, 0).unwrap();
    assert_eq!(squares.driver_name(), "mapfile");
    let map = squares.get_map().unwrap();
    assert_eq!(
        (map.info.width, map.info.height, map.info.scale),
        (w, h, 0.05)
    );
    assert_eq!((map.info.origin.px, map.info.origin.py), (-17.5, -16.5));
    for j in 0..h {
        for i in 0..w {
            let want = match shade(i, h - 1 - j) {
                0 => 1,
                128 => 0,
                _ => -1,
            };
            assert_eq!(map.cell(i, j), Some(want), "cell ({i}, {j})");
        }
    }
    // A tile reaching off the map: the request is answered, off-map cells unknown.
    let tile = squares.request_tile(w - 1, h - 1, 2, 2).unwrap();
    assert_eq!(tile[1..], [0, 0, 0]);
    // Grid drivers have no vector map.
    assert!(matches!(
        squares.get_vector(),
        Err(ClientError::Nack { .. })
    ));
    // Negated, with an origin (whose angle is ignored).
    let negated = MapProxy::new(&client, 3).unwrap().get_map().unwrap();
    assert_eq!((negated.info.origin.px, negated.info.origin.py), (1.0, 2.0));
    assert_eq!(negated.info.origin.pa, 0.0);
    let flipped: Vec<i8> = map.cells.iter().map(|&c| -c).collect();
    assert_eq!(negated.cells, flipped);

    // stage: the L-shaped model, 2 m × 2 m at (5, 5), at the world's 0.02 m.
    let lshape = MapProxy::new(&client, 1).unwrap();
    assert_eq!(lshape.driver_name(), "stage");
    let l = lshape.get_map().unwrap();
    assert_eq!(
        (l.info.width, l.info.height, l.info.scale),
        (100, 100, 0.02)
    );
    assert!((l.info.origin.px - 4.0).abs() < 1e-9 && (l.info.origin.py - 4.0).abs() < 1e-9);
    for j in 0..100 {
        for i in 0..100 {
            let want = if i < 25 || j < 25 { 1 } else { -1 };
            assert_eq!(l.cell(i, j), Some(want), "cell ({i}, {j})");
        }
    }

    // stage: the cave, 16 m square from its bitmap, against mapfile's reading of the same
    // bitmap. They differ along the walls' edges: a 0.125 m pixel is 6.25 cells of 0.02 m, and
    // a cell a wall block only partly covers is occupied; Stage's bitmap scan also shifts its
    // blocks by one pixel row (worldfile's `BitmapRows::StageCompatible`). They agree on about
    // 96% of the cells (a vertically flipped or inverted map would agree on far fewer).
    let cave_stage = MapProxy::new(&client, 2).unwrap().get_map().unwrap();
    assert_eq!((cave_stage.info.width, cave_stage.info.height), (800, 800));
    assert!(
        (cave_stage.info.origin.px + 8.0).abs() < 1e-9
            && (cave_stage.info.origin.py + 8.0).abs() < 1e-9
    );
    let cave_file = MapProxy::new(&client, 4).unwrap().get_map().unwrap();
    assert_eq!((cave_file.info.width, cave_file.info.height), (128, 128));
    let agreement = agreement(&cave_stage, &cave_file);
    let occupied = cave_stage.cells.iter().filter(|&&c| c == 1).count();
    assert!(
        occupied > 800 * 800 / 50 && occupied < 800 * 800 / 2,
        "{occupied} occupied"
    );
    assert!(
        agreement > 0.9,
        "the maps agree on {agreement:.3} of the cells"
    );

    drop((squares, lshape));
    server.shutdown();
    let _ = std::fs::remove_dir_all(dir);
}

/// The fraction of `fine`'s cells whose state is the state of the `coarse` cell their centre
/// lies in (cells of `coarse` that are unknown excepted).
fn agreement(fine: &OccupancyMap, coarse: &OccupancyMap) -> f64 {
    let (mut same, mut counted) = (0usize, 0usize);
    let (fs, cs) = (f64::from(fine.info.scale), f64::from(coarse.info.scale));
    for j in 0..fine.info.height {
        for i in 0..fine.info.width {
            let x = fine.info.origin.px + (f64::from(i) + 0.5) * fs;
            let y = fine.info.origin.py + (f64::from(j) + 0.5) * fs;
            let ci = ((x - coarse.info.origin.px) / cs).floor() as u32;
            let cj = ((y - coarse.info.origin.py) / cs).floor() as u32;
            match coarse.cell(ci, cj) {
                Some(0) | None => {}
                Some(c) => {
                    counted += 1;
                    same += usize::from(fine.cell(i, j) == Some(c));
                }
            }
        }
    }
    same as f64 / counted as f64
}

#[test]
fn a_mapfile_block_without_its_image_stops_the_server_naming_the_block() {
    let dir = scratch("missing");
    std::fs::write(
        dir.join("bad.cfg"),
        "driver ( name \"mapfile\" provides [\"map:0\"] filename \"nowhere.png\" resolution 0.1 )\n",
    )
    .unwrap();
    let cfg = CfgFile::load(&dir.join("bad.cfg"), &LoadOptions::default()).unwrap();
    let blocks = player_server::cfg::driver_blocks(&cfg, 6665).unwrap();
    let mut registry = DriverRegistry::new();
    player_drivers::register_all(&mut registry);
    let mut server = Server::new(ServerConfig::default());
    let err = server
        .add_block(&blocks[0], &mut registry)
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("bad.cfg:1"), "{err}");
    assert!(err.contains("driver \"mapfile\" failed to start"), "{err}");
    assert!(err.contains("nowhere.png"), "{err}");
    let _ = std::fs::remove_dir_all(dir);
}

/// `mapscale` and `mapcspace` read their source map from another device of the cfg (here a
/// `mapfile` written after them) through the server, and serve it transformed: what the client
/// reads equals the transform applied to the source map it reads directly.
#[test]
fn mapscale_and_mapcspace_serve_their_source_transformed() {
    use player_drivers::map::{mapcspace, mapscale};
    use player_server::map::OccupancyGrid;
    let dir = scratch("transform");
    let (w, h) = (700u32, 660u32);
    GrayImage::from_fn(w, h, |x, y| Luma([shade(x, y)]))
        .save(dir.join("squares.png"))
        .unwrap();
    let cfg = dir.join("transform.cfg");
    std::fs::write(
        &cfg,
        "driver( name \"mapscale\" provides [\"map:2\"] requires [\"map:0\"] resolution 0.25 )\n\
         driver( name \"mapcspace\" provides [\"map:3\"] requires [\"map:2\"] robot_radius 0.5 )\n\
         driver( name \"mapfile\" provides [\"map:0\"] filename \"squares.png\" resolution 0.1 )\n",
    )
    .unwrap();
    let (handle, port) = serve(&cfg);
    let client = PlayerClient::connect("localhost", port).unwrap();
    let grid = |m: &OccupancyMap| {
        OccupancyGrid::from_cells(
            m.info.width,
            m.info.height,
            m.info.scale,
            m.info.origin,
            m.cells.clone(),
        )
        .unwrap()
    };
    let source = MapProxy::new(&client, 0).unwrap().get_map().unwrap();
    let scaled = MapProxy::new(&client, 2).unwrap().get_map().unwrap();
    let expected = mapscale::scale(&grid(&source), 0.25).unwrap();
    assert_eq!((scaled.info.width, scaled.info.height), (280, 264));
    assert_eq!(scaled.info.scale, 0.25);
    assert_eq!(scaled.info.origin, source.info.origin);
    assert_eq!(scaled.cells, expected.cells());
    // A chain of two transforms: the C-space of the scaled map.
    let cspace = MapProxy::new(&client, 3).unwrap().get_map().unwrap();
    let expected = mapcspace::cspace(&expected, 0.5);
    assert_eq!(cspace.cells, expected.cells());
    assert!(
        cspace.cells.iter().filter(|&&c| c == 1).count()
            > scaled.cells.iter().filter(|&&c| c == 1).count(),
        "obstacles grew"
    );
    drop(client);
    handle.shutdown();
}
