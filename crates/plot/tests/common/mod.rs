//! Synthetic sloth poses for the plot tests and the gallery example (the real crowd run
//! lives in the sim crate, which this crate must not depend on).
#![allow(dead_code)]

use glam::{Mat3, Quat, Vec3};
use slothsim_plot::{LimbPose, SlothPose, TraceLine};
use slothsim_scene::{Scene, SupportKind};

/// Body origin's distance from the support surface (the sim's body offset, roughly).
pub const BODY_OFFSET: f32 = 0.28;

/// A seeded generator for the synthetic poses (PCG, as the rest of the workspace).
pub struct Rng(rand_pcg::Pcg64Mcg);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(rand::SeedableRng::seed_from_u64(seed))
    }
    pub fn next_u64(&mut self) -> u64 {
        rand::Rng::random(&mut self.0)
    }
    /// Uniform in 0..1.
    pub fn f32(&mut self) -> f32 {
        rand::Rng::random(&mut self.0)
    }
    pub fn below(&mut self, n: usize) -> usize {
        rand::Rng::random_range(&mut self.0, 0..n.max(1))
    }
}

/// A plausible sloth on a support: `axis_pt` on the support's axis, `forward` along it
/// (head direction), `toward` from the body to the support (+Y when hanging below a
/// branch, horizontal on a trunk), `r` the support radius there. `swing` names the limb
/// (0..4, order LF RF LH RH) that is mid-swing, if any.
pub fn sloth_on(
    id: u32,
    axis_pt: Vec3,
    forward: Vec3,
    toward: Vec3,
    r: f32,
    swing: Option<usize>,
) -> SlothPose {
    let y = toward.normalize();
    let z = (forward - y * forward.dot(y)).normalize();
    let x = y.cross(z);
    let rot = Quat::from_mat3(&Mat3::from_cols(x, y, z));
    let body_pos = axis_pt - y * (r + BODY_OFFSET);
    let hips_ws = body_pos + z * -0.25;
    let head_ws = body_pos + z * 0.45;
    let limbs = std::array::from_fn(|k| {
        let side = if k % 2 == 0 { 1.0 } else { -1.0 };
        let fore = k < 2;
        let root_ms = if fore {
            Vec3::new(0.07 * side, 0.05, 0.17)
        } else {
            Vec3::new(0.06 * side, 0.04, -0.25)
        };
        let root = body_pos + rot * root_ms;
        // Grip on the surface, on the limb's side, a little ahead/behind the root.
        let stagger = if fore { 0.08 } else { -0.02 } + if side > 0.0 { 0.04 } else { -0.04 };
        let around = (x * side * 0.8 - y * 0.6).normalize();
        let grip = axis_pt + z * (root_ms.z + stagger) + around * r;
        let planted = swing != Some(k);
        let (claw, target) = if planted {
            (grip, grip)
        } else {
            let target = grip + z * 0.18;
            (grip.lerp(target, 0.5) - y * 0.07 + x * side * 0.03, target)
        };
        let j1 = root + y * 0.05 + x * side * 0.02;
        let bend = if fore { z * 0.03 } else { -z * 0.03 };
        let j2 = j1.lerp(claw, 0.45) + x * side * 0.09 + bend;
        let j3 = j1.lerp(claw, 0.8) + x * side * 0.04;
        LimbPose {
            joints_ws: [root, j1, j2, j3, claw],
            grip_ws: target,
            planted,
        }
    });
    SlothPose {
        id,
        body_pos,
        body_rot: rot,
        head_ws,
        hips_ws,
        limbs,
    }
}

/// A sloth hanging below the branch point `axis_pt` heading along `dir`.
pub fn hanging(id: u32, axis_pt: Vec3, dir: Vec3, r: f32, swing: Option<usize>) -> SlothPose {
    sloth_on(id, axis_pt, dir, Vec3::Y, r, swing)
}

/// `n` sloths spread over the scene: ~90 % hanging below gently sloped branch segments,
/// the rest climbing trunks (head up). Also returns a 3 m trail per sloth.
pub fn crowd(scene: &Scene, n: usize, seed: u64) -> (Vec<SlothPose>, Vec<Vec<Vec3>>) {
    let mut rng = Rng::new(seed);
    let mut branch_segs = Vec::new();
    let mut trunks = Vec::new();
    for s in scene.supports() {
        match s.kind {
            SupportKind::Trunk => trunks.push(s),
            SupportKind::Branch => {
                for i in 0..s.segment_count() {
                    let d = s.nodes[i + 1] - s.nodes[i];
                    if d.y.abs() < 0.6 * d.length() {
                        branch_segs.push((s, i));
                    }
                }
            }
        }
    }
    let mut sloths = Vec::with_capacity(n);
    let mut trails = Vec::with_capacity(n);
    for id in 0..n as u32 {
        let swing = Some(rng.below(5)).filter(|&k| k < 4);
        if (rng.f32() < 0.1 || branch_segs.is_empty()) && !trunks.is_empty() {
            let t = trunks[rng.below(trunks.len())];
            let h = 0.5 + rng.f32() * 5.0;
            let base = t.nodes[0];
            let axis_pt = base + (t.nodes[1] - base).normalize() * h;
            let ang = rng.f32() * std::f32::consts::TAU;
            let out = Vec3::new(ang.cos(), 0.0, ang.sin());
            let r = t.radii[0];
            sloths.push(sloth_on(id, axis_pt, Vec3::Y, -out, r, swing));
            trails.push(vec![
                axis_pt + out * (r + BODY_OFFSET) - Vec3::Y * 2.0,
                axis_pt + out * (r + BODY_OFFSET),
            ]);
        } else if !branch_segs.is_empty() {
            let (s, i) = branch_segs[rng.below(branch_segs.len())];
            let (a, b) = (s.nodes[i], s.nodes[i + 1]);
            let t = rng.f32();
            let p = a.lerp(b, t);
            let r = s.radii[i] + (s.radii[i + 1] - s.radii[i]) * t;
            let reverse = rng.f32() < 0.5;
            let dir = if reverse { a - b } else { b - a };
            sloths.push(hanging(id, p, dir, r, swing));
            // Trail: back along the support's polyline, about 3 m, below the axis.
            let mut trail = vec![p - Vec3::Y * (r + BODY_OFFSET)];
            let mut left = 3.0f32;
            let mut cur = p;
            let mut j = i as isize + if reverse { 1 } else { 0 };
            while left > 0.0 && j >= 0 && (j as usize) < s.nodes.len() {
                let node = s.nodes[j as usize];
                let d = cur.distance(node);
                let q = if d > left {
                    cur.lerp(node, left / d)
                } else {
                    node
                };
                trail.push(q - Vec3::Y * (r + BODY_OFFSET));
                left -= d;
                cur = node;
                j += if reverse { 1 } else { -1 };
            }
            trails.push(trail);
        }
    }
    (sloths, trails)
}

/// A fake step search of the sloth's fore limbs: candidates from 0.5 m ahead back in
/// 5 cm steps, from the limb's side toward the support; the farthest ones miss.
pub fn step_search(sloth: &SlothPose, r: f32) -> Vec<TraceLine> {
    let x = sloth.body_rot * Vec3::X;
    let y = sloth.body_rot * Vec3::Y;
    let z = sloth.body_rot * Vec3::Z;
    let axis_pt = sloth.body_pos + y * (r + BODY_OFFSET);
    let mut out = Vec::new();
    for side in [1.0f32, -1.0] {
        for step in 0..8 {
            let d = 0.5 - step as f32 * 0.05;
            let from = axis_pt + z * (0.17 + d) + x * side * 0.35 - y * 0.1;
            let target = axis_pt + z * (0.17 + d) + x * side * r;
            let hit = step >= 3;
            let to = if hit {
                target
            } else {
                from + (target - from) * 1.6 - z * 0.0 + y * 0.25
            };
            out.push(TraceLine { from, to, hit });
        }
    }
    out
}

/// A sloth walking along `dir` on a horizontal branch at `start`, sampled at `n`
/// instants over `seconds` (speed 0.1 m/s), limbs swinging in DSDC order.
pub fn walk(start: Vec3, dir: Vec3, r: f32, n: usize, seconds: f32) -> Vec<(f32, SlothPose)> {
    let order = [3usize, 0, 2, 1];
    (0..n)
        .map(|i| {
            let t = if n > 1 {
                seconds * i as f32 / (n - 1) as f32
            } else {
                0.0
            };
            let p = start + dir.normalize() * (0.1 * t);
            let swing = Some(order[i % 4]);
            (t, hanging(0, p, dir, r, swing))
        })
        .collect()
}
