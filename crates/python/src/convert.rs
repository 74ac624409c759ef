//! Player message bodies as Python values.
//!
//! DATA bodies become dicts whose keys are libplayerc's field names (`px`, `ranges`,
//! `blobs`, ...), so the Python proxies copy them onto themselves without a second table of
//! names; geometry and configuration replies use the same shapes. Poses are lists
//! (`[x, y, yaw]` or `[x, y, z, roll, pitch, yaw]`), as SWIG returns libplayerc's arrays.

use player_proto::*;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};

/// The interfaces the Python modules address, by their Player constant names
/// (`PLAYER_POSITION2D_CODE`, ...). Exported on the module so Python never repeats a code.
pub const INTERFACES: &[(&str, InterfaceCode)] = &[
    ("PLAYER_PLAYER_CODE", InterfaceCode::PLAYER),
    ("PLAYER_POSITION2D_CODE", InterfaceCode::POSITION2D),
    ("PLAYER_RANGER_CODE", InterfaceCode::RANGER),
    ("PLAYER_LASER_CODE", InterfaceCode::LASER),
    ("PLAYER_SONAR_CODE", InterfaceCode::SONAR),
    ("PLAYER_BLOBFINDER_CODE", InterfaceCode::BLOBFINDER),
    ("PLAYER_FIDUCIAL_CODE", InterfaceCode::FIDUCIAL),
    ("PLAYER_GRIPPER_CODE", InterfaceCode::GRIPPER),
    ("PLAYER_SIMULATION_CODE", InterfaceCode::SIMULATION),
    ("PLAYER_SPEECH_CODE", InterfaceCode::SPEECH),
    ("PLAYER_GRAPHICS2D_CODE", InterfaceCode::GRAPHICS2D),
    ("PLAYER_GRAPHICS3D_CODE", InterfaceCode::GRAPHICS3D),
    ("PLAYER_ACTARRAY_CODE", InterfaceCode::ACTARRAY),
    ("PLAYER_LOG_CODE", InterfaceCode::LOG),
    ("PLAYER_CAMERA_CODE", InterfaceCode::CAMERA),
    ("PLAYER_MAP_CODE", InterfaceCode::MAP),
    ("PLAYER_PLANNER_CODE", InterfaceCode::PLANNER),
    ("PLAYER_LOCALIZE_CODE", InterfaceCode::LOCALIZE),
];

/// `[px, py, pa]`.
pub fn pose2d(p: &Pose2d) -> [f64; 3] {
    [p.px, p.py, p.pa]
}

/// `[px, py, pz, proll, ppitch, pyaw]`.
pub fn pose3d(p: &Pose3d) -> [f64; 6] {
    [p.px, p.py, p.pz, p.proll, p.ppitch, p.pyaw]
}

/// `[sw, sl, sh]`.
pub fn bbox3d(b: &Bbox3d) -> [f64; 3] {
    [b.sw, b.sl, b.sh]
}

/// A device's pose and size as libplayerc's geometry fields: `{pose: [6], size: [3]}`.
pub fn pose_size<'py>(
    py: Python<'py>,
    pose: &Pose3d,
    size: &Bbox3d,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("pose", pose3d(pose))?;
    d.set_item("size", bbox3d(size))?;
    Ok(d)
}

/// libplayerc's position2d odometry fields (`px py pa vx vy va stall`), from a server's DATA
/// or an in-process `World`'s position model alike, so the Python side reads both one way.
pub fn odometry<'py>(
    d: &Bound<'py, PyDict>,
    pos: [f64; 3],
    vel: [f64; 3],
    stall: impl IntoPyObject<'py>,
) -> PyResult<()> {
    for (key, v) in ["px", "py", "pa"].into_iter().zip(pos) {
        d.set_item(key, v)?;
    }
    for (key, v) in ["vx", "vy", "va"].into_iter().zip(vel) {
        d.set_item(key, v)?;
    }
    d.set_item("stall", stall)
}

/// A ranger's geometry: `device_pose`, `device_size`, `element_poses`, `element_sizes`
/// (libplayerc's `playerc_ranger_t` names).
pub fn ranger_geom<'py>(py: Python<'py>, g: &RangerGeom) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("device_pose", pose3d(&g.pose))?;
    d.set_item("device_size", bbox3d(&g.size))?;
    let poses: Vec<[f64; 6]> = g.element_poses.iter().map(pose3d).collect();
    let sizes: Vec<[f64; 3]> = g.element_sizes.iter().map(bbox3d).collect();
    d.set_item("element_count", poses.len())?;
    d.set_item("element_poses", poses)?;
    d.set_item("element_sizes", sizes)?;
    Ok(d)
}

/// A ranger's configuration under libplayerc's names.
pub fn ranger_config<'py>(py: Python<'py>, c: &RangerConfig) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("min_angle", c.min_angle)?;
    d.set_item("max_angle", c.max_angle)?;
    d.set_item("angular_res", c.angular_res)?;
    d.set_item("min_range", c.min_range)?;
    d.set_item("max_range", c.max_range)?;
    d.set_item("range_res", c.range_res)?;
    d.set_item("frequency", c.frequency)?;
    Ok(d)
}

/// A laser's configuration under libplayerc's names (`scan_res`, `scanning_frequency`, ...).
pub fn laser_config<'py>(py: Python<'py>, c: &LaserConfig) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("min_angle", c.min_angle)?;
    d.set_item("max_angle", c.max_angle)?;
    d.set_item("scan_res", c.resolution)?;
    d.set_item("max_range", c.max_range)?;
    d.set_item("range_res", c.range_res)?;
    d.set_item("intensity_on", c.intensity)?;
    d.set_item("scanning_frequency", c.scanning_frequency)?;
    Ok(d)
}

fn laser_scan(d: &Bound<'_, PyDict>, ranges: &[f32], bearings: &[f64]) -> PyResult<()> {
    let scan: Vec<[f64; 2]> = ranges
        .iter()
        .zip(bearings)
        .map(|(&r, &b)| [f64::from(r), b])
        .collect();
    let points: Vec<[f64; 2]> = scan
        .iter()
        .map(|[r, b]| [r * b.cos(), r * b.sin()])
        .collect();
    d.set_item("scan_count", ranges.len())?;
    d.set_item(
        "ranges",
        ranges.iter().map(|&r| f64::from(r)).collect::<Vec<_>>(),
    )?;
    d.set_item("scan", scan)?;
    d.set_item("point", points)?;
    Ok(())
}

/// One DATA body as a dict of libplayerc fields; `None` for bodies the Python proxies do not
/// read (they keep their previous values, as libplayerc ignores unknown subtypes).
pub fn data<'py>(py: Python<'py>, body: &Body) -> PyResult<Option<Bound<'py, PyDict>>> {
    let d = PyDict::new(py);
    match body {
        Body::Position2d(Position2dMsg::Data(Position2dData::State(s))) => {
            odometry(&d, pose2d(&s.pos), pose2d(&s.vel), s.stall)?;
        }
        Body::Position2d(Position2dMsg::Data(Position2dData::Geom(g))) => {
            d.set_item("pose", pose3d(&g.pose))?;
            d.set_item("size", bbox3d(&g.size))?;
        }
        Body::Ranger(RangerMsg::Data(r)) => match r {
            RangerData::Range(r) => ranger_ranges(&d, &r.ranges)?,
            RangerData::RangeStamped(r) => {
                ranger_ranges(&d, &r.data.ranges)?;
                if r.have_geom != 0 {
                    d.update(ranger_geom(py, &r.geom)?.as_mapping())?;
                }
                if r.have_config != 0 {
                    d.update(ranger_config(py, &r.config)?.as_mapping())?;
                }
            }
            RangerData::Intns(i) => ranger_intensities(&d, &i.intensities)?,
            RangerData::IntnsStamped(i) => {
                ranger_intensities(&d, &i.data.intensities)?;
                if i.have_geom != 0 {
                    d.update(ranger_geom(py, &i.geom)?.as_mapping())?;
                }
                if i.have_config != 0 {
                    d.update(ranger_config(py, &i.config)?.as_mapping())?;
                }
            }
            RangerData::Geom(g) => d.update(ranger_geom(py, g)?.as_mapping())?,
        },
        Body::Laser(LaserMsg::Data(l)) => {
            let (scan, pose) = match l {
                LaserData::Scan(s) => (s, None),
                LaserData::ScanPose(s) => (&s.scan, Some(s.pose)),
                LaserData::ScanAngle(s) => {
                    let bearings: Vec<f64> = s.angles.iter().map(|&a| f64::from(a)).collect();
                    laser_scan(&d, &s.ranges, &bearings)?;
                    d.set_item("max_range", s.max_range)?;
                    d.set_item("intensity", s.intensity.clone())?;
                    d.set_item("scan_id", s.id)?;
                    return Ok(Some(d));
                }
            };
            let n = scan.ranges.len();
            let step = if n > 1 {
                f64::from(scan.max_angle - scan.min_angle) / (n - 1) as f64
            } else {
                0.0
            };
            let bearings: Vec<f64> = (0..n)
                .map(|i| f64::from(scan.min_angle) + step * i as f64)
                .collect();
            laser_scan(&d, &scan.ranges, &bearings)?;
            d.set_item("min_angle", scan.min_angle)?;
            d.set_item("max_angle", scan.max_angle)?;
            d.set_item("scan_res", scan.resolution)?;
            d.set_item("max_range", scan.max_range)?;
            d.set_item("intensity", scan.intensity.clone())?;
            d.set_item("scan_id", scan.id)?;
            if let Some(p) = pose {
                d.set_item("robot_pose", pose2d(&p))?;
            }
        }
        Body::Sonar(SonarMsg::Data(SonarData::Ranges(s))) => {
            let scan: Vec<f64> = s.ranges.iter().map(|&r| f64::from(r)).collect();
            d.set_item("scan_count", scan.len())?;
            d.set_item("scan", scan)?;
        }
        Body::Sonar(SonarMsg::Data(SonarData::Geom(g))) => sonar_geom(&d, g)?,
        Body::Blobfinder(BlobfinderMsg::Data(BlobfinderData::Blobs(b))) => {
            d.set_item("width", b.width)?;
            d.set_item("height", b.height)?;
            d.set_item("blobs_count", b.blobs.len())?;
            let blobs = PyList::empty(py);
            for blob in &b.blobs {
                let e = PyDict::new(py);
                e.set_item("id", blob.id)?;
                e.set_item("color", blob.color)?;
                e.set_item("area", blob.area)?;
                e.set_item("x", blob.x)?;
                e.set_item("y", blob.y)?;
                e.set_item("left", blob.left)?;
                e.set_item("right", blob.right)?;
                e.set_item("top", blob.top)?;
                e.set_item("bottom", blob.bottom)?;
                e.set_item("range", blob.range)?;
                blobs.append(e)?;
            }
            d.set_item("blobs", blobs)?;
        }
        Body::Fiducial(FiducialMsg::Data(FiducialData::Scan(s))) => {
            d.set_item("fiducials_count", s.fiducials.len())?;
            let items = PyList::empty(py);
            for f in &s.fiducials {
                let e = PyDict::new(py);
                e.set_item("id", f.id)?;
                e.set_item("pose", pose3d(&f.pose))?;
                e.set_item("upose", pose3d(&f.upose))?;
                items.append(e)?;
            }
            d.set_item("fiducials", items)?;
        }
        Body::Gripper(GripperMsg::Data(GripperData::State(s))) => {
            d.set_item("state", s.state)?;
            d.set_item("beams", s.beams)?;
            d.set_item("stored", s.stored)?;
        }
        Body::Camera(CameraMsg::Data(CameraData::State(c))) => {
            d.set_item("width", c.width)?;
            d.set_item("height", c.height)?;
            d.set_item("bpp", c.bpp)?;
            d.set_item("format", c.format)?;
            d.set_item("fdiv", c.fdiv)?;
            d.set_item("compression", c.compression)?;
            d.set_item("image_count", c.image.len())?;
            d.set_item("image", PyBytes::new(py, &c.image))?;
        }
        Body::Planner(PlannerMsg::Data(PlannerDataMsg::State(p))) => {
            d.set_item("path_valid", p.valid)?;
            d.set_item("path_done", p.done)?;
            d.set_item("px", p.pos.px)?;
            d.set_item("py", p.pos.py)?;
            d.set_item("pa", p.pos.pa)?;
            d.set_item("gx", p.goal.px)?;
            d.set_item("gy", p.goal.py)?;
            d.set_item("ga", p.goal.pa)?;
            d.set_item("wx", p.waypoint.px)?;
            d.set_item("wy", p.waypoint.py)?;
            d.set_item("wa", p.waypoint.pa)?;
            d.set_item("curr_waypoint", p.waypoint_idx)?;
            d.set_item("waypoint_count", p.waypoints_count)?;
        }
        Body::Localize(LocalizeMsg::Data(LocalizeData::Hypoths(h))) => {
            d.set_item("pending_count", h.pending_count)?;
            d.set_item("pending_time", h.pending_time)?;
            d.set_item("hypoth_count", h.hypoths.len())?;
            let items = PyList::empty(py);
            for hyp in &h.hypoths {
                let e = PyDict::new(py);
                e.set_item("mean", pose2d(&hyp.mean))?;
                e.set_item("cov", hyp.cov)?;
                e.set_item("alpha", hyp.alpha)?;
                items.append(e)?;
            }
            d.set_item("hypoths", items)?;
        }
        Body::Map(MapMsg::Data(MapData::Info(i))) => map_info(&d, i)?,
        Body::Actarray(ActarrayMsg::Data(ActarrayData::State(s))) => {
            let items = PyList::empty(py);
            for a in &s.actuators {
                let e = PyDict::new(py);
                e.set_item("position", a.position)?;
                e.set_item("speed", a.speed)?;
                e.set_item("acceleration", a.acceleration)?;
                e.set_item("current", a.current)?;
                e.set_item("state", a.state)?;
                items.append(e)?;
            }
            d.set_item("actuators_count", s.actuators.len())?;
            d.set_item("actuators_data", items)?;
            d.set_item("motor_state", s.motor_state)?;
        }
        _ => return Ok(None),
    }
    Ok(Some(d))
}

fn ranger_ranges(d: &Bound<'_, PyDict>, ranges: &[f64]) -> PyResult<()> {
    d.set_item("ranges_count", ranges.len())?;
    d.set_item("ranges", ranges)
}

fn ranger_intensities(d: &Bound<'_, PyDict>, intensities: &[f64]) -> PyResult<()> {
    d.set_item("intensities_count", intensities.len())?;
    d.set_item("intensities", intensities)
}

/// A sonar's geometry: `pose_count` and `poses` (`[x, y, yaw]` each, as libplayerc keeps).
pub fn sonar_geom(d: &Bound<'_, PyDict>, g: &SonarGeom) -> PyResult<()> {
    let poses: Vec<[f64; 3]> = g.poses.iter().map(|p| [p.px, p.py, p.pyaw]).collect();
    d.set_item("pose_count", poses.len())?;
    d.set_item("poses", poses)
}

/// A map's metadata under libplayerc's names (`resolution`, `width`, `height`, `origin`).
pub fn map_info(d: &Bound<'_, PyDict>, i: &MapInfo) -> PyResult<()> {
    d.set_item("resolution", i.scale)?;
    d.set_item("width", i.width)?;
    d.set_item("height", i.height)?;
    d.set_item("origin", [i.origin.px, i.origin.py])?;
    Ok(())
}
