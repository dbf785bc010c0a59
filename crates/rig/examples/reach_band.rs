//! Reachable band along a horizontal pole for the left fore and hind limbs:
//! which grips (claw tip on the pole's side) a limb reaches within its joint
//! limits, for a body hanging `h` metres below the pole's axis.
//!
//! `cargo run --release -p slothsim-rig --example reach_band -- [h] [radius]`
//!
//! For each grip along the pole (body-relative z, every 1 cm) CCD (with the
//! limit-aware polish) is started from the neutral pose and from random
//! within-limit poses; a grip counts as reached when one start gets the claw
//! within 1.5 mm. Prints, per limb, the reached z range relative to the
//! limb's chain root and to its girdle joint.
use glam::{Quat, Vec3, Vec3A};
use slothsim_rig::{CcdParams, ChainPose, JointLimit, Limb, LimbChain, Rig, RootTransform, solve};

fn rnd(state: &mut u64) -> f32 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    (*state >> 40) as f32 / (1u64 << 24) as f32
}

/// A left chain like `sloth.rs` builds, from bone (length, pitch°), splay° and girdle offset.
fn chain(limb: Limb, bones: [(f32, f32); 4], splay_deg: f32, root: Vec3) -> LimbChain {
    let s = Quat::from_rotation_z(-splay_deg.to_radians());
    let b = bones.map(|(l, p)| {
        let p = p.to_radians();
        s * Vec3::new(0.0, p.cos(), p.sin()) * l
    });
    let amp = limb.amplitudes_deg().map(f32::to_radians);
    let hinge = Vec3A::from(s * Vec3::X);
    let limits = [
        JointLimit::ball_amplitude(Vec3A::from(b[0].normalize()), amp[0]),
        JointLimit::ball_amplitude(Vec3A::from(b[1].normalize()), amp[1]),
        JointLimit::hinge_amplitude(hinge, amp[2]),
        JointLimit::hinge_amplitude(hinge, amp[3]),
    ];
    LimbChain::new(
        limb,
        [root.into(), b[0].into(), b[1].into(), b[2].into()],
        [Quat::IDENTITY; 4],
        b[3].into(),
        limits,
    )
}

/// Reached z (relative to the chain root) of grips at (radius, h, z) relative to the chain root.
fn band(c: &LimbChain, h: f32, radius: f32, starts: usize) -> Vec<f32> {
    band_step(c, h, radius, starts, 1)
}

fn band_step(c: &LimbChain, h: f32, radius: f32, starts: usize, step_cm: i32) -> Vec<f32> {
    let params = CcdParams::default();
    let mut s = 11u64;
    let mut reached = vec![];
    for k in (-50..=50).step_by(step_cm as usize) {
        let z = k as f32 * 0.01;
        let target = Vec3::new(radius, h, z);
        let mut best = f32::INFINITY;
        for start in 0..starts {
            let mut pose = if start == 0 {
                ChainPose::NEUTRAL
            } else {
                let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                c.sample_pose(&u)
            };
            let r = solve(c, RootTransform::IDENTITY, target, &mut pose, &params);
            best = best.min(r.error);
            if best < 1.5e-3 {
                break;
            }
        }
        if best < 1.5e-3 {
            reached.push(z);
        }
    }
    reached
}

/// Longest run of consecutive reached grips (metres) and its centre.
fn longest(r: &[f32], step: f32) -> (f32, f32) {
    let (mut best, mut centre) = (0.0f32, 0.0f32);
    let mut i = 0;
    while i < r.len() {
        let mut j = i;
        while j + 1 < r.len() && r[j + 1] - r[j] < step * 1.5 {
            j += 1;
        }
        if r[j] - r[i] > best {
            best = r[j] - r[i];
            centre = 0.5 * (r[i] + r[j]);
        }
        i = j + 1;
    }
    (best, centre)
}

fn show(name: &str, r: &[f32]) {
    let (len, c) = longest(r, 0.01);
    println!(
        "  {name}: longest run {:.0} cm centred at {c:+.3}; all {r:.2?}",
        len * 100.0
    );
    match (r.first(), r.last()) {
        (Some(a), Some(b)) => println!(
            "  {name}: z {a:+.2}..{b:+.2} ({} reached of {:.0} cm span)",
            r.len(),
            (b - a) * 100.0 + 1.0
        ),
        _ => println!("  {name}: nothing reached"),
    }
}

fn parse4(s: &str) -> [f32; 4] {
    let v: Vec<f32> = s.split(',').map(|x| x.parse().expect("number")).collect();
    [v[0], v[1], v[2], v[3]]
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let get = |k: &str| {
        args.iter()
            .position(|a| a == k)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let h: f32 = get("--h").map_or(0.295, |s| s.parse().unwrap());
    let radius: f32 = get("--r").map_or(0.02, |s| s.parse().unwrap());
    let fore = get("--fore").map_or([10.0, -35.0, 30.0, 45.0], |s| parse4(&s));
    let hind = get("--hind").map_or([0.0, 45.0, -20.0, -60.0], |s| parse4(&s));
    let fsplay: f32 = get("--fsplay").map_or(15.0, |s| s.parse().unwrap());
    let hsplay: f32 = get("--hsplay").map_or(12.0, |s| s.parse().unwrap());
    let starts: usize = get("--starts").map_or(40, |s| s.parse().unwrap());
    let fl = [0.06, 0.14, 0.13, 0.07];
    let hl = [0.05, 0.15, 0.13, 0.07];
    // The left fore or hind chain with bone pitches `pit` (degrees).
    let limb_chain = |fore_limb: bool, pit: [f32; 4]| {
        if fore_limb {
            chain(
                Limb::LF,
                std::array::from_fn(|i| (fl[i], pit[i])),
                fsplay,
                Vec3::new(0.07, 0.05, 0.0),
            )
        } else {
            chain(
                Limb::LH,
                std::array::from_fn(|i| (hl[i], pit[i])),
                hsplay,
                Vec3::new(0.06, 0.04, 0.0),
            )
        }
    };
    let fc = limb_chain(true, fore);
    let hc = limb_chain(false, hind);
    if let Some(which) = get("--local") {
        let fore_limb = which == "fore";
        let base = if fore_limb { fore } else { hind };
        let n = 4i32;
        let idx = |a: i32, b: i32, c: i32| {
            (((a + n) * (2 * n + 1) + (b + n)) * (2 * n + 1) + (c + n)) as usize
        };
        let mut lens = vec![0.0f32; ((2 * n + 1) as usize).pow(3)];
        let mut cen = lens.clone();
        for a in -n..=n {
            for b in -n..=n {
                for c in -n..=n {
                    let pit = [
                        base[0],
                        base[1] + 5.0 * a as f32,
                        base[2] + 5.0 * b as f32,
                        base[3] + 5.0 * c as f32,
                    ];
                    let ch = limb_chain(fore_limb, pit);
                    let hr = if fore_limb { h - 0.02 } else { h };
                    let r = band_step(&ch, hr, radius, starts, 2);
                    let (len, centre) = longest(&r, 0.02);
                    lens[idx(a, b, c)] = len;
                    cen[idx(a, b, c)] = centre;
                }
            }
        }
        let mut res = vec![];
        for a in -n..=n {
            for b in -n..=n {
                for c in -n..=n {
                    let mut robust = lens[idx(a, b, c)];
                    for (da, db, dc) in [
                        (1, 0, 0),
                        (-1, 0, 0),
                        (0, 1, 0),
                        (0, -1, 0),
                        (0, 0, 1),
                        (0, 0, -1),
                    ] {
                        let (x, y, z) = (a + da, b + db, c + dc);
                        if x.abs() <= n && y.abs() <= n && z.abs() <= n {
                            robust = robust.min(lens[idx(x, y, z)]);
                        }
                    }
                    let pit = [
                        base[0],
                        base[1] + 5.0 * a as f32,
                        base[2] + 5.0 * b as f32,
                        base[3] + 5.0 * c as f32,
                    ];
                    res.push((robust, lens[idx(a, b, c)], cen[idx(a, b, c)], pit));
                }
            }
        }
        res.sort_by(|a, b| b.0.total_cmp(&a.0).then(b.1.total_cmp(&a.1)));
        for r in res.iter().take(25) {
            println!(
                "robust {:.2} len {:.2} centre {:+.3} pitches {:?}",
                r.0, r.1, r.2, r.3
            );
        }
        return;
    }
    if let Some(which) = get("--sweep") {
        let hs: Vec<f32> = get("--hs").map_or(vec![h], |s| {
            s.split(',').map(|x| x.parse().unwrap()).collect()
        });
        let fore_limb = which == "fore";
        let mut res = vec![];
        for &hh in &hs {
            for p1 in (-40..=70).step_by(10) {
                for p2 in (-90..=60).step_by(15) {
                    for p3 in (-80..=60).step_by(20) {
                        let p0 = if fore_limb { fore[0] } else { hind[0] };
                        let pit = [p0, p1 as f32, p2 as f32, p3 as f32];
                        let c = limb_chain(fore_limb, pit);
                        let hr = if fore_limb { hh - 0.02 } else { hh };
                        let r = band_step(&c, hr, radius, starts, 2);
                        let (len, centre) = longest(&r, 0.02);
                        res.push((len, centre, hh, pit));
                    }
                }
            }
        }
        res.sort_by(|a, b| b.0.total_cmp(&a.0));
        for r in res.iter().take(40) {
            println!(
                "len {:.2} centre {:+.3} h {:.3} pitches {:?}",
                r.0, r.1, r.2, r.3
            );
        }
        return;
    }
    if args.iter().any(|a| a == "--check") {
        let rig = Rig::sloth();
        assert_eq!(rig.chain(Limb::LF), &fc, "fore");
        assert_eq!(rig.chain(Limb::LH), &hc, "hind");
        println!("default chains match the rig");
    }
    // Chest sits 0.02 m above the body origin, Hips at it.
    let hf = h - 0.02;
    println!("h {h} (fore chain root {hf:.3} / hind {h:.3} below the axis), radius {radius}");
    println!(
        "  fore neutral tip {:?}",
        fc.fk(RootTransform::IDENTITY, &ChainPose::NEUTRAL)[4]
    );
    println!(
        "  hind neutral tip {:?}",
        hc.fk(RootTransform::IDENTITY, &ChainPose::NEUTRAL)[4]
    );
    let f = band(&fc, hf, radius, starts);
    let b = band(&hc, h, radius, starts);
    show("fore", &f);
    show("hind", &b);
}
