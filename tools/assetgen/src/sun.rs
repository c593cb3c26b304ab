//! Where the sun's light goes once it has passed a window, and the camera presets placed from
//! it. The generator refuses to write a scene in which some window's light would fall on
//! nothing (or leave through another window): the renderer's projectors only show on the floor
//! and walls.

use anyhow::{Result, bail};
use glam::Vec3;

use crate::geom::{Class, Object, Scene};

/// Barycentric weights of the sample points taken on each window triangle.
const SAMPLES: [[f32; 3]; 4] = [
    [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
    [0.6, 0.2, 0.2],
    [0.2, 0.6, 0.2],
    [0.2, 0.2, 0.6],
];

/// What the light through one window hits.
#[derive(Clone, Debug)]
pub struct WindowLight {
    pub material: String,
    /// cos of the angle between the sunlight and the window's inward normal; > 0 when lit.
    pub incidence: f32,
    pub samples: usize,
    /// Samples whose ray first hits the floor or a wall.
    pub received: usize,
    pub on_floor: usize,
    /// Names of anything else a ray hit first (or "nothing" for rays that escaped).
    pub lost: Vec<String>,
    /// Mean of the points where the light lands.
    pub landing: Vec3,
}

/// The first object (index) hit along the ray, ignoring `skip` and the background.
pub fn first_hit(objects: &[Object], skip: usize, origin: Vec3, dir: Vec3) -> Option<(usize, f32)> {
    let mut best: Option<(usize, f32)> = None;
    for (k, obj) in objects.iter().enumerate() {
        if k == skip || obj.class == Class::Background {
            continue;
        }
        for &t in &obj.triangles {
            let hit = geom::intersect(obj.corners(t), origin, dir).map(|(d, _)| d);
            if let Some(d) = hit.filter(|&d| best.is_none_or(|(_, b)| d < b)) {
                best = Some((k, d));
            }
        }
    }
    best
}

/// Traces sunlight through sample points of every window.
pub fn trace(scene: &Scene) -> Vec<WindowLight> {
    let sun = scene.layout.sun;
    scene
        .windows
        .iter()
        .map(|w| {
            let obj = scene.window_object(w);
            let mut light = WindowLight {
                material: w.material.clone(),
                incidence: sun.dot(w.inward),
                samples: 0,
                received: 0,
                on_floor: 0,
                lost: Vec::new(),
                landing: Vec3::ZERO,
            };
            for &t in &obj.triangles {
                let [a, b, c] = obj.corners(t);
                for s in SAMPLES {
                    let p = a * s[0] + b * s[1] + c * s[2];
                    light.samples += 1;
                    match first_hit(&scene.objects, w.object, p, sun) {
                        Some((k, d)) if scene.objects[k].class.receives_light() => {
                            light.received += 1;
                            light.on_floor += (scene.objects[k].class == Class::Floor) as usize;
                            light.landing += p + sun * d;
                        }
                        Some((k, _)) => light.lost.push(scene.objects[k].name.clone()),
                        None => light.lost.push("nothing".into()),
                    }
                }
            }
            light.landing /= light.received.max(1) as f32;
            light
        })
        .collect()
}

/// Fails unless the sun shines in through every window and all of its light lands on the floor
/// or a wall.
pub fn check(lights: &[WindowLight]) -> Result<()> {
    for l in lights {
        if l.incidence <= 0.05 {
            bail!(
                "the sun does not shine in through {} (cos incidence {:.3})",
                l.material,
                l.incidence
            );
        }
        if l.received != l.samples {
            bail!(
                "{} of {} sun rays through {} miss the floor and walls (first hit: {})",
                l.samples - l.received,
                l.samples,
                l.material,
                l.lost.join(", ")
            );
        }
    }
    Ok(())
}

#[derive(Clone, Debug, PartialEq)]
pub struct CameraPreset {
    pub name: &'static str,
    pub note: &'static str,
    pub position: Vec3,
    pub target: Vec3,
    pub fov_y_deg: f32,
}

/// Rounds to centimetres, as the manifest prints positions.
fn cm(v: Vec3) -> Vec3 {
    (v * 100.0).round() / 100.0
}

/// Camera presets, placed from the layout and from where the light actually lands.
pub fn cameras(scene: &Scene, lights: &[WindowLight]) -> Vec<CameraPreset> {
    let l = &scene.layout;
    let length = l.length();
    let mid = l.bays / 2;
    let lower_mid = lights
        .iter()
        .find(|w| w.material == format!("window_lower_{}", mid + 1))
        .map_or(Vec3::new(0.0, 0.0, l.bay_centre(mid)), |w| w.landing);
    let pool = Vec3::new(lower_mid.x, 0.0, lower_mid.z);
    let upper_y = (l.upper.sill + l.upper.apex()) / 2.0;
    vec![
        CameraPreset {
            name: "nave",
            note: "down the corridor from the entrance, towards the rose",
            position: cm(Vec3::new(0.0, 1.7, -0.6)),
            target: cm(Vec3::new(0.0, 5.5, -length)),
            fov_y_deg: 60.0,
        },
        CameraPreset {
            name: "clerestory",
            note: "from the shaded side, looking up at the upper windows",
            position: cm(Vec3::new(-l.half_width + 1.2, 1.6, -length * 0.3)),
            target: cm(Vec3::new(l.half_width, upper_y, -length * 0.55)),
            fov_y_deg: 65.0,
        },
        CameraPreset {
            name: "floor",
            note: "down onto the coloured light cast by the middle lower window",
            position: cm(Vec3::new(-l.half_width + 0.8, 5.0, pool.z + 5.0)),
            target: cm(pool),
            fov_y_deg: 55.0,
        },
        CameraPreset {
            name: "rose",
            note: "facing the rose window in the end wall",
            position: cm(Vec3::new(0.0, 4.0, -length + 11.0)),
            target: cm(Vec3::new(0.0, l.rose_centre_y, -length)),
            fov_y_deg: 50.0,
        },
        CameraPreset {
            name: "glass",
            note: "close to a lower window, to see the glass itself",
            position: cm(Vec3::new(0.5, 2.5, l.bay_centre(mid) - 1.5)),
            target: cm(Vec3::new(
                l.half_width,
                (l.lower.sill + l.lower.apex()) / 2.0,
                l.bay_centre(mid),
            )),
            fov_y_deg: 60.0,
        },
    ]
}
