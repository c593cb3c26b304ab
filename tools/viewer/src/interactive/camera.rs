//! The fly camera: position plus yaw and pitch (no roll, so the horizon stays level while
//! flying), and smooth transitions to the pack's camera presets.

use glam::Vec3;
use render::View;

/// Pitch stops short of straight up or down, where yaw would be undefined.
const MAX_PITCH: f32 = 1.55;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub position: Vec3,
    /// Radians about +Y; 0 looks down −Z.
    pub yaw: f32,
    /// Radians above the horizon.
    pub pitch: f32,
    pub fov_y_deg: f32,
}

impl Pose {
    pub fn looking(position: Vec3, forward: Vec3, fov_y_deg: f32) -> Self {
        let f = forward.normalize_or_zero();
        let f = if f == Vec3::ZERO { Vec3::NEG_Z } else { f };
        Self {
            position,
            yaw: f.x.atan2(-f.z),
            pitch: f.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH),
            fov_y_deg,
        }
    }

    pub fn from_camera(c: &pack::Camera) -> Self {
        let p = Vec3::from(c.position);
        Self::looking(p, Vec3::from(c.target) - p, c.fov_y)
    }

    pub fn forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(sy * cp, sp, -cy * cp)
    }

    /// Forward projected on the ground plane, for walking.
    fn ground_forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        Vec3::new(sy, 0.0, -cy)
    }

    fn right(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        Vec3::new(cy, 0.0, sy)
    }

    /// Interpolates towards `to`, turning the short way round.
    fn lerp(&self, to: &Pose, t: f32) -> Pose {
        let mut dyaw = (to.yaw - self.yaw) % std::f32::consts::TAU;
        if dyaw > std::f32::consts::PI {
            dyaw -= std::f32::consts::TAU;
        } else if dyaw < -std::f32::consts::PI {
            dyaw += std::f32::consts::TAU;
        }
        Pose {
            position: self.position.lerp(to.position, t),
            yaw: self.yaw + dyaw * t,
            pitch: self.pitch + (to.pitch - self.pitch) * t,
            fov_y_deg: self.fov_y_deg + (to.fov_y_deg - self.fov_y_deg) * t,
        }
    }
}

/// Which movement keys are held.
#[derive(Clone, Copy, Debug, Default)]
pub struct MoveKeys {
    pub forward: bool,
    pub back: bool,
    pub left: bool,
    pub right: bool,
    pub up: bool,
    pub down: bool,
    pub fast: bool,
    pub slow: bool,
}

impl MoveKeys {
    fn direction(&self, pose: &Pose) -> Vec3 {
        let axis = |pos: bool, neg: bool| pos as i32 as f32 - neg as i32 as f32;
        pose.ground_forward() * axis(self.forward, self.back)
            + pose.right() * axis(self.right, self.left)
            + Vec3::Y * axis(self.up, self.down)
    }
}

struct Transition {
    from: Pose,
    to: Pose,
    elapsed: f32,
    duration: f32,
}

pub struct FlyCamera {
    pub pose: Pose,
    pub near: f32,
    pub far: f32,
    /// Scene units per second at normal speed.
    pub speed: f32,
    /// Radians per pixel of mouse movement.
    pub sensitivity: f32,
    transition: Option<Transition>,
}

impl FlyCamera {
    /// A camera at `pose`, with speed and clip planes scaled to a scene of `size` (the length
    /// of its bounding box diagonal), so a toy scene and a cathedral both fly sensibly.
    pub fn new(pose: Pose, size: f32, near: f32, far: f32) -> Self {
        let size = if size.is_finite() && size > 0.0 {
            size
        } else {
            10.0
        };
        Self {
            pose,
            near,
            far,
            speed: size * 0.2,
            sensitivity: 0.003,
            transition: None,
        }
    }

    /// Starts a smooth move to `to`; flying or looking cancels it.
    pub fn go_to(&mut self, to: Pose, near: f32, far: f32, duration: f32) {
        self.near = near;
        self.far = far;
        self.transition = Some(Transition {
            from: self.pose,
            to,
            elapsed: 0.0,
            duration: duration.max(1e-3),
        });
    }

    #[cfg(test)]
    pub fn in_transition(&self) -> bool {
        self.transition.is_some()
    }

    pub fn look(&mut self, dx: f32, dy: f32) {
        if dx == 0.0 && dy == 0.0 {
            return;
        }
        self.transition = None;
        self.pose.yaw = (self.pose.yaw + dx * self.sensitivity) % std::f32::consts::TAU;
        self.pose.pitch = (self.pose.pitch - dy * self.sensitivity).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Advances by `dt` seconds: the transition if one runs, else the held movement keys.
    pub fn update(&mut self, keys: &MoveKeys, dt: f32) {
        let dt = if dt.is_finite() {
            dt.clamp(0.0, 0.25)
        } else {
            0.0
        };
        let dir = keys.direction(&self.pose);
        if dir != Vec3::ZERO {
            self.transition = None;
            let factor = if keys.fast {
                4.0
            } else if keys.slow {
                0.25
            } else {
                1.0
            };
            self.pose.position += dir.normalize() * self.speed * factor * dt;
        }
        if let Some(t) = &mut self.transition {
            t.elapsed += dt;
            let x = (t.elapsed / t.duration).min(1.0);
            // Smoothstep: starts and stops gently, so the jump reads as a camera move.
            let s = x * x * (3.0 - 2.0 * x);
            self.pose = t.from.lerp(&t.to, s);
            if x >= 1.0 {
                self.pose = t.to;
                self.transition = None;
            }
        }
    }

    pub fn view(&self, aspect: f32) -> View {
        View::look(
            self.pose.position,
            self.pose.forward(),
            Vec3::Y,
            self.pose.fov_y_deg,
            aspect,
            self.near,
            self.far,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pose_round_trips_its_forward_vector() {
        for f in [
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(1.0, 0.2, 0.0),
            Vec3::new(-0.3, -0.5, 0.8),
        ] {
            let p = Pose::looking(Vec3::ZERO, f, 60.0);
            assert!((p.forward() - f.normalize()).length() < 1e-5, "{f}");
        }
    }

    #[test]
    fn walking_stays_level_and_strafing_is_perpendicular() {
        let mut cam = FlyCamera::new(
            Pose::looking(Vec3::ZERO, Vec3::new(1.0, -0.7, 0.0), 60.0),
            10.0,
            0.1,
            100.0,
        );
        let keys = MoveKeys {
            forward: true,
            ..Default::default()
        };
        cam.update(&keys, 0.1);
        let p = cam.pose.position;
        assert!(p.y.abs() < 1e-6 && p.x > 0.0, "{p}");
        let before = cam.pose.position;
        cam.update(
            &MoveKeys {
                right: true,
                fast: true,
                ..Default::default()
            },
            0.1,
        );
        let d = cam.pose.position - before;
        assert!(d.dot(Vec3::X).abs() < 1e-6 && d.z > 0.0, "{d}");
        // Fast is four times normal speed.
        assert!((d.length() - 4.0 * (p - Vec3::ZERO).length()).abs() < 1e-4);
    }

    #[test]
    fn transition_ends_exactly_on_the_preset_and_turns_the_short_way() {
        let from = Pose {
            position: Vec3::ZERO,
            yaw: 3.0,
            pitch: 0.0,
            fov_y_deg: 60.0,
        };
        let to = Pose {
            position: Vec3::new(4.0, 1.0, 2.0),
            yaw: -3.0,
            pitch: 0.3,
            fov_y_deg: 45.0,
        };
        let mut cam = FlyCamera::new(from, 10.0, 0.1, 100.0);
        cam.go_to(to, 0.1, 100.0, 0.5);
        cam.update(&MoveKeys::default(), 0.25);
        // Halfway through a turn of 0.28 rad across ±π, not 6 rad the long way.
        let yaw = cam.pose.yaw;
        assert!(yaw > 3.0 && yaw < 3.3, "{yaw}");
        for _ in 0..10 {
            cam.update(&MoveKeys::default(), 0.1);
        }
        assert!(!cam.in_transition());
        assert_eq!(cam.pose, to);
    }

    #[test]
    fn looking_clamps_pitch_and_cancels_a_transition() {
        let mut cam = FlyCamera::new(Pose::looking(Vec3::ZERO, Vec3::NEG_Z, 60.0), 1.0, 0.1, 10.0);
        cam.go_to(Pose::looking(Vec3::ONE, Vec3::X, 60.0), 0.1, 10.0, 1.0);
        cam.look(0.0, -1e6);
        assert!(!cam.in_transition());
        assert!(cam.pose.pitch <= MAX_PITCH);
        let v = cam.view(16.0 / 9.0);
        assert!(v.view_proj().is_finite());
    }
}
