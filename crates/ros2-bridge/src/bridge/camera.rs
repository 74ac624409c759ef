//! A vehicle's cameras as stage_ros2's `camera.cpp` publishes them: `image` (rgba8), `depth`
//! (32FC1 metres with `is_depth_canonical`, else 16UC1 millimetres, REP 118), `camera_info`
//! (a pinhole model from the fields of view) and the `camera` optical frame. The engine
//! ray-casts the images headless; its depth is the distance along each pixel's ray, which is
//! turned here into REP 118's depth along the optical axis (what Stage's OpenGL depth buffer
//! gave stage_ros2).

use stage_sim::{CameraDesc, CameraImage, ModelId, ModelType, World};

use super::{Out, Outbound, Topics, default_qos, stamp};
use crate::Error;
use crate::msgs::{CameraInfo, Image, Quaternion, Transform, TransformStamped, Vector3};
use crate::names::{CameraNames, VehicleNames};
use crate::params::Params;

/// One camera of a vehicle and its publishers.
pub(super) struct Camera {
    model: ModelId,
    frame: String,
    image: Outbound<Image>,
    depth: Outbound<Image>,
    info: Outbound<CameraInfo>,
    /// The sim time of the last image published (images go out once, when fresh).
    last_us: u64,
}

/// The cameras whose parent is `vehicle` (as stage_ros2 finds them), subscribed so that they
/// render, each with its publishers.
pub(super) fn cameras_of(
    world: &mut World,
    topics: &mut Topics,
    vehicle: ModelId,
    names: &VehicleNames,
) -> Result<Vec<Camera>, Error> {
    let models: Vec<ModelId> = world
        .children(vehicle)
        .map_err(Error::Sim)?
        .filter(|c| world.model_type(*c).ok() == Some(ModelType::Camera))
        .collect();
    let several = models.len() > 1;
    let mut out = Vec::new();
    for (k, &m) in models.iter().enumerate() {
        world.subscribe(m).map_err(Error::Sim)?;
        let CameraNames {
            image,
            depth,
            camera_info,
            frame,
        } = names.camera(k + 1, several);
        out.push(Camera {
            model: m,
            frame,
            image: Outbound::new(topics, &image, default_qos())?,
            depth: Outbound::new(topics, &depth, default_qos())?,
            info: Outbound::new(topics, &camera_info, default_qos())?,
            last_us: 0,
        });
    }
    Ok(out)
}

impl Camera {
    /// Publishes the image, the depth image and the camera info when the camera has a fresh
    /// image (each built only when a reader is matched).
    pub(super) fn publish(&mut self, world: &World, params: &Params, out: &mut Out<'_>) {
        let (Ok(img), Ok(cfg)) = (
            world.camera_image(self.model),
            world.camera_config(self.model),
        ) else {
            return;
        };
        if img.time_us == 0 || img.time_us == self.last_us || img.width == 0 || img.height == 0 {
            return;
        }
        self.last_us = img.time_us;
        let frame = &self.frame;
        self.image.send(out, || Image {
            header: stamp(frame, img.time_us),
            height: img.height,
            width: img.width,
            encoding: "rgba8".into(),
            is_bigendian: 0,
            step: img.width * 4,
            data: img.rgba.clone(),
        });
        self.depth
            .send(out, || depth_image(frame, img, cfg, params));
        self.info.send(out, || camera_info(frame, img, cfg));
    }

    /// The transform from the vehicle's body frame to the camera's optical frame (z ahead, x
    /// right, y down), where the engine renders from: the vehicle's x and y, the camera's
    /// centre height, the vehicle's heading turned by the camera's pan and tilt.
    pub(super) fn transform(
        &self,
        world: &World,
        vehicle: ModelId,
        names: &VehicleNames,
    ) -> Option<TransformStamped> {
        let cfg = world.camera_config(self.model).ok()?;
        let cam = world.global_pose(self.model).ok()?;
        let body = world.global_pose(vehicle).ok()?;
        let size = world.node(self.model).ok()?.size;
        let [pan, tilt] = cfg.pantilt;
        Some(TransformStamped {
            header: stamp(&names.frame_base_link, 0),
            child_frame_id: self.frame.clone(),
            transform: Transform {
                translation: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: cam.z + size[2] / 2.0 - body.z,
                },
                // stage_ros2's roll - pi/2 and yaw - pi/2 turn the body frame into the
                // optical frame; the engine's tilt is positive upwards
                rotation: from_roll_yaw(
                    tilt - std::f64::consts::FRAC_PI_2,
                    pan - std::f64::consts::FRAC_PI_2,
                ),
            },
        })
    }
}

/// A rotation about x by `roll`, then about z by `yaw` (tf2's `setRPY(roll, 0, yaw)`).
fn from_roll_yaw(roll: f64, yaw: f64) -> Quaternion {
    let (sr, cr) = (roll / 2.0).sin_cos();
    let (sy, cy) = (yaw / 2.0).sin_cos();
    Quaternion {
        x: sr * cy,
        y: sr * sy,
        z: cr * sy,
        w: cr * cy,
    }
}

/// For each pixel, the cosine between its ray and the optical axis (depth along the axis =
/// distance along the ray x this), from the engine's ray layout: columns evenly spaced in
/// azimuth across the horizontal field of view, rows in elevation across the vertical one.
fn axis_factors(img: &CameraImage, cfg: &CameraDesc) -> Vec<f64> {
    let (w, h) = (img.width as usize, img.height as usize);
    let [fov_h, fov_v] = cfg.fov;
    let tilt = cfg.pantilt[1];
    let cols: Vec<f64> = (0..w)
        .map(|c| (fov_h / 2.0 - (c as f64 + 0.5) * fov_h / w as f64).cos())
        .collect();
    let mut out = Vec::with_capacity(w * h);
    for row in 0..h {
        let el = tilt + fov_v / 2.0 - (row as f64 + 0.5) * fov_v / h as f64;
        let (a, b) = (el.cos() * tilt.cos(), el.sin() * tilt.sin());
        out.extend(cols.iter().map(|c| a * c + b));
    }
    out
}

/// The depth image as stage_ros2 forms it (REP 118): 32FC1 metres with -inf nearer than the
/// near clip and +inf at or beyond the far one (nothing seen), or 16UC1 millimetres with 0 for
/// both.
fn depth_image(frame: &str, img: &CameraImage, cfg: &CameraDesc, params: &Params) -> Image {
    let [near, far] = cfg.range;
    let factors = axis_factors(img, cfg);
    let canonical = params.is_depth_canonical;
    let mut data = Vec::with_capacity(img.depth.len() * if canonical { 4 } else { 2 });
    for (&d, f) in img.depth.iter().zip(factors) {
        let d = f64::from(d);
        let z = d * f;
        if canonical {
            let v = if d <= near {
                f32::NEG_INFINITY
            } else if d >= far {
                f32::INFINITY
            } else {
                z as f32
            };
            data.extend_from_slice(&v.to_le_bytes());
        } else {
            let (near_mm, far_mm) = ((near * 1000.0) as i64, (far * 1000.0) as i64);
            let v = (z * 1000.0) as i64;
            let v = if (d * 1000.0) as i64 <= near_mm || (d * 1000.0) as i64 >= far_mm {
                0
            } else {
                v.clamp(0, i64::from(u16::MAX)) as u16
            };
            data.extend_from_slice(&v.to_le_bytes());
        }
    }
    Image {
        header: stamp(frame, img.time_us),
        height: img.height,
        width: img.width,
        encoding: if canonical { "32FC1" } else { "16UC1" }.into(),
        is_bigendian: 0,
        step: img.width * if canonical { 4 } else { 2 },
        data,
    }
}

/// stage_ros2's pinhole model: focal lengths from the fields of view, the principal point at
/// the image's centre, no distortion.
fn camera_info(frame: &str, img: &CameraImage, cfg: &CameraDesc) -> CameraInfo {
    let (w, h) = (f64::from(img.width), f64::from(img.height));
    let fx = w / (2.0 * (cfg.fov[0] / 2.0).tan());
    let fy = h / (2.0 * (cfg.fov[1] / 2.0).tan());
    let (cx, cy) = (w / 2.0, h / 2.0);
    CameraInfo {
        header: stamp(frame, img.time_us),
        height: img.height,
        width: img.width,
        distortion_model: String::new(),
        d: vec![0.0; 4],
        k: [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
        r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p: [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
        ..CameraInfo::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: u32, h: u32, depth: Vec<f32>) -> CameraImage {
        CameraImage {
            time_us: 100_000,
            width: w,
            height: h,
            rgba: vec![0; (w * h * 4) as usize],
            depth,
        }
    }

    fn desc(fov_deg: [f64; 2], range: [f64; 2]) -> CameraDesc {
        CameraDesc {
            resolution: [2, 2],
            range,
            fov: [fov_deg[0].to_radians(), fov_deg[1].to_radians()],
            pantilt: [0.0, 0.0],
        }
    }

    #[test]
    fn depth_is_along_the_optical_axis_with_reps_clipping() {
        // 2x2 with 90 x 90 degree fields: every pixel's ray is 22.5 degrees off the axis in
        // azimuth and elevation
        let cfg = desc([90.0, 90.0], [0.5, 8.0]);
        let img = image(2, 2, vec![2.0, 8.0, 0.4, 3.0]);
        let c = 22.5f64.to_radians().cos();
        let mut p = Params {
            is_depth_canonical: true,
            ..Params::default()
        };
        let d = depth_image("camera", &img, &cfg, &p);
        assert_eq!((d.encoding.as_str(), d.step), ("32FC1", 8));
        let v: Vec<f32> = d
            .data
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        assert_eq!(v[0], (2.0 * c * c) as f32);
        assert_eq!((v[1], v[2]), (f32::INFINITY, f32::NEG_INFINITY));
        assert_eq!(v[3], (3.0 * c * c) as f32);

        p.is_depth_canonical = false;
        let d = depth_image("camera", &img, &cfg, &p);
        assert_eq!((d.encoding.as_str(), d.step), ("16UC1", 4));
        let v: Vec<u16> = d
            .data
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes(b.try_into().unwrap()))
            .collect();
        assert_eq!(v, [(2000.0 * c * c) as u16, 0, 0, (3000.0 * c * c) as u16]);
    }

    #[test]
    fn camera_info_is_stage_ros2s_pinhole() {
        let cfg = desc([90.0, 60.0], [0.5, 8.0]);
        let info = camera_info("camera", &image(4, 2, vec![1.0; 8]), &cfg);
        let fy = 2.0 / (2.0 * 30f64.to_radians().tan());
        assert!((info.k[0] - 2.0).abs() < 1e-12 && (info.k[4] - fy).abs() < 1e-12);
        assert_eq!((info.k[2], info.k[5], info.k[8]), (2.0, 1.0, 1.0));
        assert_eq!(
            (info.p[0], info.p[5], info.p[2], info.p[6]),
            (info.k[0], fy, 2.0, 1.0)
        );
        assert_eq!(info.d, [0.0; 4]);
    }

    #[test]
    fn the_optical_frame_looks_along_the_body_x_axis() {
        // rotate the optical axes by q: z (ahead) -> +x, x (right) -> -y, y (down) -> -z
        let q = from_roll_yaw(-std::f64::consts::FRAC_PI_2, -std::f64::consts::FRAC_PI_2);
        let rot = |v: [f64; 3]| {
            let (x, y, z, w) = (q.x, q.y, q.z, q.w);
            let u = [x, y, z];
            let cross = |a: [f64; 3], b: [f64; 3]| {
                [
                    a[1] * b[2] - a[2] * b[1],
                    a[2] * b[0] - a[0] * b[2],
                    a[0] * b[1] - a[1] * b[0],
                ]
            };
            let t = cross(u, v).map(|c| 2.0 * c);
            let c2 = cross(u, t);
            [0, 1, 2].map(|i| v[i] + w * t[i] + c2[i])
        };
        let close = |a: [f64; 3], b: [f64; 3]| a.iter().zip(b).all(|(p, q)| (p - q).abs() < 1e-12);
        assert!(close(rot([0.0, 0.0, 1.0]), [1.0, 0.0, 0.0]));
        assert!(close(rot([1.0, 0.0, 0.0]), [0.0, -1.0, 0.0]));
        assert!(close(rot([0.0, 1.0, 0.0]), [0.0, 0.0, -1.0]));
    }
}
