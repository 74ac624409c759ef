//! Our `stage` against the original Stage 4.1.1 `stage`, run as whole programs on the same
//! worldfiles: the issue compared them that way (wall time from start to exit, loading
//! included), and only whole runs catch costs outside the step loop (parsing, bitmaps, start-up).
//!
//! Run: `cargo bench -p cli --bench vs_original -- --original PATH` (or set
//! `PLAYERSTAGE_ORIGINAL_STAGE`), where PATH is an original `stage` binary, e.g. a locally built
//! Stage 4.1.1 with its `LD_LIBRARY_PATH` and `STAGEPATH` set in the environment (its
//! `expand_swarm` and `expand_pioneer` controllers are found through `STAGEPATH`). Nothing
//! upstream is built here. Without an original, only our times are printed.
//!
//! Worlds: Stage's `simple.world` (its own quit_time, 3600 s), `benchmark/cave.world` (60 s: a
//! `quit_time 60` line is added to a temporary copy, as the original has no quit-time flag),
//! `benchmark/hospital.world` (its own 60 s) and `swarm10000`, a generated file of 10,000
//! hospital-style swarm robots (`--swarm-seconds S`, default 10). Both binaries read the same
//! temporary copy. Original: `stage -g FILE`; ours: `stage -g --fast FILE`. Runs alternate
//! original, ours, original, ours ... so that a machine whose speed drifts affects both alike.
//!
//! Each world ends with the range of the time ratios, their median and the ratio of the two
//! programs' fastest runs (the runs a drifting machine disturbed least).
//!
//! Options: `--runs N` (default 3 of each), `--worlds simple,cave,hospital,swarm10000` (a
//! subset), `--swarm-seconds S`, `--original PATH`.

use std::fmt::Write as _;
use std::fs;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::Instant;

use clap::Parser;

/// The worlds, by the name `--worlds` takes, in the order they run.
const WORLDS: [&str; 4] = ["simple", "cave", "hospital", "swarm10000"];

/// Robots in the generated swarm world: the largest swarm.
const SWARM_ROBOTS: usize = 10_000;

/// Simulated seconds the copy of cave.world runs (it has no quit_time of its own).
const CAVE_SECONDS: u32 = 60;

/// Whole-program timing of the original Stage 4.1.1 `stage` against ours.
#[derive(Parser, Debug)]
#[command(name = "vs_original")]
struct Args {
    /// The original `stage` binary (else `$PLAYERSTAGE_ORIGINAL_STAGE`).
    #[arg(long, value_name = "PATH")]
    original: Option<PathBuf>,
    /// Runs of each binary per world.
    #[arg(long, value_name = "N", default_value_t = 3)]
    runs: usize,
    /// Which worlds to run (comma-separated): simple, cave, hospital, swarm10000.
    #[arg(
        long,
        value_name = "LIST",
        value_delimiter = ',',
        default_value = "simple,cave,hospital,swarm10000"
    )]
    worlds: Vec<String>,
    /// Simulated seconds of the generated swarm10000 world (its quit_time).
    #[arg(long, value_name = "S", default_value_t = 10.0)]
    swarm_seconds: f64,
    /// Passed by `cargo bench` to every bench; ignored.
    #[arg(long, hide = true)]
    bench: bool,
}

/// How one run of a binary ended.
struct Outcome {
    /// Wall seconds from spawn to exit.
    secs: f64,
    /// Peak resident set size, in KiB (the child's `ru_maxrss`).
    max_rss_kib: i64,
    /// `None` for a clean exit, else what went wrong (status, signal, last stderr line).
    failure: Option<String>,
}

/// The temporary copy of the world tree; removed when dropped, on every way out.
struct Scratch(PathBuf);

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.0);
    }
}

fn main() -> ExitCode {
    let args = Args::parse();
    for w in &args.worlds {
        if !WORLDS.contains(&w.as_str()) {
            eprintln!("unknown world {w:?}: --worlds takes {}", WORLDS.join(","));
            return ExitCode::from(2);
        }
    }
    if args.runs == 0 || !(args.swarm_seconds > 0.0 && args.swarm_seconds.is_finite()) {
        eprintln!("--runs must be at least 1 and --swarm-seconds a positive number");
        return ExitCode::from(2);
    }
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!(
        "vs_original: original Stage 4.1.1 `stage -g` against ours `stage -g --fast`, wall time \
         from spawn to exit (loading included), peak RSS"
    );
    println!(
        "machine: {cpus} CPUs (nproc); timings on shared VMs drift by several per cent within \
         minutes, so compare the alternating runs of one session, not separate sessions"
    );
    let Some(worlds) = test_support::stage_worlds() else {
        println!(
            "skipping vs_original: Stage's worlds not found (set PLAYERSTAGE_SHARED to a folder \
             holding stage-worlds/, or put it at ../shared/stage-worlds beside the workspace)"
        );
        return ExitCode::SUCCESS;
    };
    let ours = PathBuf::from(env!("CARGO_BIN_EXE_stage"));
    let original = original_binary(args.original.clone());
    match &original {
        Ok(p) => println!("original: {}", p.display()),
        Err(why) => println!(
            "original: {why}, running ours alone (pass --original PATH or set \
             PLAYERSTAGE_ORIGINAL_STAGE to an executable Stage 4.1.1 `stage`)"
        ),
    }
    let original = original.ok();
    println!("ours: {}", ours.display());
    println!(
        "worlds: {}; runs of each binary per world: {}",
        worlds.display(),
        args.runs
    );

    let scratch = match prepare(&worlds, &args, cpus) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("could not prepare the worlds in a temporary folder: {e}");
            return ExitCode::FAILURE;
        }
    };
    let mut any_failed = false;
    for name in WORLDS
        .iter()
        .filter(|w| args.worlds.iter().any(|a| a == *w))
    {
        let (file, what) = match *name {
            "simple" => (
                "simple.world".to_string(),
                "its quit_time 3600 s".to_string(),
            ),
            "cave" => (
                "benchmark/cave.world".to_string(),
                format!("quit_time {CAVE_SECONDS} s added to the copy"),
            ),
            "hospital" => (
                "benchmark/hospital.world".to_string(),
                "its quit_time 60 s".to_string(),
            ),
            _ => (
                format!("swarm{SWARM_ROBOTS}.world"),
                format!(
                    "generated, {SWARM_ROBOTS} robots, quit_time {} s",
                    args.swarm_seconds
                ),
            ),
        };
        println!();
        println!("{file} ({what})");
        let path = scratch.0.join(&file);
        any_failed |= !bench_world(&path, original.as_deref(), &ours, args.runs);
    }
    drop(scratch);
    if any_failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

/// The original binary from the flag or the environment if it is an executable file, else
/// why not (for the one line that says how to give it).
fn original_binary(flag: Option<PathBuf>) -> Result<PathBuf, String> {
    let p = flag
        .or_else(|| std::env::var_os("PLAYERSTAGE_ORIGINAL_STAGE").map(PathBuf::from))
        .ok_or("not given")?;
    let executable = fs::metadata(&p)
        .map(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
        .unwrap_or(false);
    if executable {
        Ok(p)
    } else {
        Err(format!("{} is not an executable file", p.display()))
    }
}

/// Copies Stage's world tree into a fresh temporary folder, gives the copy of cave.world its
/// quit_time and writes the swarm world beside simple.world, so both binaries read the same bytes.
fn prepare(worlds: &Path, args: &Args, cpus: usize) -> std::io::Result<Scratch> {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let dir = std::env::temp_dir().join(format!(
        "playerstage-vs-original-{}-{nanos}",
        std::process::id()
    ));
    let scratch = Scratch(dir);
    copy_tree(worlds, &scratch.0)?;
    let cave = scratch.0.join("benchmark/cave.world");
    let text = fs::read_to_string(&cave)?;
    fs::write(&cave, with_quit_time(&text, CAVE_SECONDS))?;
    fs::write(
        scratch.0.join(format!("swarm{SWARM_ROBOTS}.world")),
        swarm_worldfile(SWARM_ROBOTS, args.swarm_seconds, cpus, 1),
    )?;
    Ok(scratch)
}

/// Copies a folder recursively (following symbolic links).
fn copy_tree(from: &Path, to: &Path) -> std::io::Result<()> {
    fs::create_dir_all(to)?;
    for entry in fs::read_dir(from)? {
        let entry = entry?;
        let (src, dst) = (entry.path(), to.join(entry.file_name()));
        if fs::metadata(&src)?.is_dir() {
            copy_tree(&src, &dst)?;
        } else {
            fs::copy(&src, &dst)?;
        }
    }
    Ok(())
}

/// `text` with a top-level `quit_time` line after its `threads` line (or at the end when it
/// has none), so a world without one stops on its own under both binaries.
fn with_quit_time(text: &str, secs: u32) -> String {
    let line = format!("quit_time {secs} # added by the vs_original bench\n");
    let mut out = String::with_capacity(text.len() + line.len());
    let mut added = false;
    for l in text.split_inclusive('\n') {
        out.push_str(l);
        if !added && l.trim_start().starts_with("threads") {
            if !l.ends_with('\n') {
                out.push('\n');
            }
            out.push_str(&line);
            added = true;
        }
    }
    if !added {
        if !out.ends_with('\n') {
            out.push('\n');
        }
        out.push_str(&line);
    }
    out
}

/// A small deterministic generator for the swarm world's poses and colours (Knuth's MMIX LCG,
/// top 53 bits): the file must be the same on every run, and need not match `swarm_world`'s.
struct Lcg(u64);

impl Lcg {
    /// The next number in [0, 1).
    fn next_f64(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    /// The next number in [lo, hi).
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }
}

/// A plain Stage worldfile with the layout of `stage_sim::generate::swarm_world(n, _)`: a
/// walled square arena of about 1 m² per robot, one 0.3 m obstacle per 4 robots, and `n`
/// hospital.world `swarmbot`s (0.1 m, 12 one-sample 2 m IR rangers, `expand_swarm`) on a 1 m
/// grid. Written as text both binaries load, rather than built in memory, so the original can
/// run it. `threads` is the machine's CPU count so the original may use every core, as ours does.
fn swarm_worldfile(n: usize, quit_secs: f64, threads: usize, seed: u64) -> String {
    let side = (n as f64).sqrt().ceil().max(2.0);
    let half = side / 2.0 + 0.5;
    let (t, w) = (0.05, 2.0 * half);
    let mut rng = Lcg(seed);
    let mut s = String::new();
    // writing to a String cannot fail
    let _ = writeln!(
        s,
        "# swarm{n}.world - generated by playerstage-rs's vs_original bench: {n} swarm robots\n\
         # in a walled {w:.1} m square with {} obstacles\n\n\
         resolution 0.02\nspeedup -1\npaused 0\nthreads {threads}\nquit_time {quit_secs}\n",
        n / 4
    );
    s.push_str(
        "define ir sensor\n(\n  samples 1\n  range [0 2]\n  fov 30\n  color_rgba [1 0 0 0.3]\n)\n\n\
         define swarmbot position\n(\n  size [0.100 0.100 0.100]\n  ranger\n  (\n    pose [0 0 -0.050 0]\n",
    );
    for k in 0..12 {
        let _ = writeln!(s, "    ir( pose [0 0 0 {}] )", 30 * k);
    }
    s.push_str("  )\n  ctrl \"expand_swarm\"\n)\n\n");
    // the arena: one model, four wall blocks whose bounding box is exactly its size
    let _ = writeln!(
        s,
        "model\n(\n  name \"arena\"\n  size [{w:.3} {w:.3} 0.500]\n  pose [0 0 0 0]\n  color \"black\"\n  gui_move 0"
    );
    for [x, y, dx, dy] in [
        [-half, -half, w, t],
        [-half, half - t, w, t],
        [-half, -half, t, w],
        [half - t, -half, t, w],
    ] {
        let _ = writeln!(
            s,
            "  block( points 4 point[0] [{:.3} {:.3}] point[1] [{:.3} {:.3}] point[2] [{:.3} {:.3}] \
             point[3] [{:.3} {:.3}] z [0 0.5] )",
            x,
            y,
            x + dx,
            y,
            x + dx,
            y + dy,
            x,
            y + dy
        );
    }
    s.push_str(")\n\n");
    for i in 0..n / 4 {
        let (x, y) = (
            rng.uniform(-half + 0.5, half - 0.5),
            rng.uniform(-half + 0.5, half - 0.5),
        );
        let a = rng.uniform(-180.0, 180.0);
        let _ = writeln!(
            s,
            "model( name \"obstacle{i}\" pose [{x:.3} {y:.3} 0 {a:.1}] size [0.300 0.300 0.500] \
             color_rgba [0.5 0.5 0.5 1] )"
        );
    }
    s.push('\n');
    let per_row = side as usize;
    for i in 0..n {
        let x = -side / 2.0 + 0.5 + (i % per_row) as f64;
        let y = -side / 2.0 + 0.5 + (i / per_row) as f64;
        let a = rng.uniform(-180.0, 180.0);
        let (r, g) = (rng.next_f64(), rng.next_f64());
        let _ = writeln!(
            s,
            "swarmbot( name \"r{i}\" pose [{x:.3} {y:.3} 0 {a:.1}] color_rgba [{r:.2} {g:.2} 1 1] )"
        );
    }
    s
}

/// Runs the binaries alternately on one world, prints each run and a summary; false if a run
/// failed (the world's remaining runs are then skipped: a failure repeats, and costs time).
fn bench_world(world: &Path, original: Option<&Path>, ours: &Path, runs: usize) -> bool {
    let mut orig_runs: Vec<Outcome> = Vec::new();
    let mut our_runs: Vec<Outcome> = Vec::new();
    for run in 1..=runs {
        let mut line = format!("  run {run}");
        if let Some(o) = original {
            let out = run_once(o, &[], world);
            let _ = write!(line, "  original {}", describe(&out));
            let failed = out.failure.is_some();
            orig_runs.push(out);
            if failed {
                println!("{line}");
                break;
            }
        }
        let out = run_once(ours, &["--fast"], world);
        let _ = write!(line, "  ours {}", describe(&out));
        let failed = out.failure.is_some();
        if let (Some(o), None) = (orig_runs.last(), &out.failure) {
            let _ = write!(line, "  ratio {:.2}x", o.secs / out.secs);
        }
        our_runs.push(out);
        println!("{line}");
        if failed {
            break;
        }
    }
    let failures: Vec<String> = orig_runs
        .iter()
        .map(|o| ("original", o))
        .chain(our_runs.iter().map(|o| ("ours", o)))
        .filter_map(|(who, o)| o.failure.as_ref().map(|f| format!("{who} {f}")))
        .collect();
    if !failures.is_empty() {
        println!("  FAILED: {}", failures.join("; "));
        return false;
    }
    let mut summary = String::from(" ");
    if original.is_some() {
        let _ = write!(summary, " original {}", time_range(&orig_runs));
        let _ = write!(summary, ", ours {}", time_range(&our_runs));
        let mut ratios: Vec<f64> = orig_runs
            .iter()
            .zip(&our_runs)
            .map(|(o, u)| o.secs / u.secs)
            .collect();
        ratios.sort_by(f64::total_cmp);
        // each program's fastest run is the one a drifting machine disturbed least
        let best = |runs: &[Outcome]| runs.iter().map(|o| o.secs).fold(f64::INFINITY, f64::min);
        let _ = write!(
            summary,
            ", ratio {:.2}–{:.2}x (median {:.2}x, best against best {:.2}x)",
            ratios[0],
            ratios[ratios.len() - 1],
            median(&ratios),
            best(&orig_runs) / best(&our_runs)
        );
        let _ = write!(
            summary,
            "; peak RSS original {}, ours {}",
            mib(peak(&orig_runs)),
            mib(peak(&our_runs))
        );
    } else {
        let _ = write!(
            summary,
            " ours {}; peak RSS {}",
            time_range(&our_runs),
            mib(peak(&our_runs))
        );
    }
    println!("{summary}");
    true
}

/// Runs `bin [-g] [extra] FILE` in the world's folder, output discarded except the last
/// line of stderr, which is kept for a failure's report; times it and reads its peak RSS.
fn run_once(bin: &Path, extra: &[&str], world: &Path) -> Outcome {
    let dir = world.parent().unwrap_or(Path::new("."));
    let name = world.file_name().unwrap_or_default();
    let err_path = dir.join(format!(".vs_original-{}.stderr", std::process::id()));
    let failed = |secs, msg: String| Outcome {
        secs,
        max_rss_kib: 0,
        failure: Some(msg),
    };
    let err_file = match fs::File::create(&err_path) {
        Ok(f) => f,
        Err(e) => return failed(0.0, format!("could not create a stderr file: {e}")),
    };
    let t0 = Instant::now();
    let child = Command::new(bin)
        .arg("-g")
        .args(extra)
        .arg(name)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(err_file)
        .spawn();
    let child = match child {
        Ok(c) => c,
        Err(e) => return failed(0.0, format!("did not start: {e}")),
    };
    let (status, rusage) = match wait_with_rusage(child.id() as libc::pid_t) {
        Ok(r) => r,
        Err(e) => return failed(t0.elapsed().as_secs_f64(), format!("wait4 failed: {e}")),
    };
    let secs = t0.elapsed().as_secs_f64();
    let stderr = fs::read_to_string(&err_path).unwrap_or_default();
    let _ = fs::remove_file(&err_path);
    let last = stderr
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("")
        .trim();
    let failure = if libc::WIFEXITED(status) {
        let code = libc::WEXITSTATUS(status);
        (code != 0).then(|| format!("exited with status {code} (stderr: {last:?})"))
    } else if libc::WIFSIGNALED(status) {
        Some(format!(
            "killed by signal {} (stderr: {last:?})",
            libc::WTERMSIG(status)
        ))
    } else {
        Some(format!("ended with wait status {status:#x}"))
    };
    Outcome {
        secs,
        max_rss_kib: rusage.ru_maxrss,
        failure,
    }
}

/// Waits for the child `pid` with `wait4`, which also returns its resource usage: the kernel's
/// peak RSS is exact, where sampling `/proc/PID/status` while it runs can miss a short peak.
fn wait_with_rusage(pid: libc::pid_t) -> std::io::Result<(libc::c_int, libc::rusage)> {
    let mut status: libc::c_int = 0;
    // SAFETY: rusage is plain old data, valid when zeroed.
    let mut rusage: libc::rusage = unsafe { std::mem::zeroed() };
    loop {
        // SAFETY: both pointers are to live locals; pid is our own unreaped child (std's
        // Child never waits on drop, so nothing else reaps it).
        let r = unsafe { libc::wait4(pid, &mut status, 0, &mut rusage) };
        if r == pid {
            return Ok((status, rusage));
        }
        let e = std::io::Error::last_os_error();
        if e.kind() != std::io::ErrorKind::Interrupted {
            return Err(e);
        }
    }
}

/// One run for its line: seconds and peak RSS, or FAILED.
fn describe(o: &Outcome) -> String {
    match o.failure {
        None => format!("{:8.2} s {:>10}", o.secs, mib(o.max_rss_kib)),
        Some(_) => "FAILED".into(),
    }
}

/// "min–max s" of the runs.
fn time_range(runs: &[Outcome]) -> String {
    let min = runs.iter().map(|o| o.secs).fold(f64::INFINITY, f64::min);
    let max = runs.iter().map(|o| o.secs).fold(0.0, f64::max);
    format!("{min:.2}–{max:.2} s")
}

/// The largest peak RSS of the runs, in KiB.
fn peak(runs: &[Outcome]) -> i64 {
    runs.iter().map(|o| o.max_rss_kib).max().unwrap_or(0)
}

/// KiB as "N.N MiB".
fn mib(kib: i64) -> String {
    format!("{:.1} MiB", kib as f64 / 1024.0)
}

/// The median of sorted, non-empty values.
fn median(sorted: &[f64]) -> f64 {
    let n = sorted.len();
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        (sorted[n / 2 - 1] + sorted[n / 2]) / 2.0
    }
}
