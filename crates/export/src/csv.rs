//! `trajectories.csv`: one row per recorded sloth per sample.

use std::io::Write;
use std::path::Path;

use crate::{AtomicFile, ExportError, Sample};

/// The header of `trajectories.csv` (schema in `docs/export.md`): time,
/// sloth id, body position and rotation (quaternion x, y, z, w), then per
/// limb (LF, RF, LH, RH) its grip point, planted flag (1/0) and the grip's
/// support id, and the kind of support under the body.
pub const CSV_HEADER: &str = "t,id,x,y,z,qx,qy,qz,qw,\
LF_grip_x,LF_grip_y,LF_grip_z,LF_planted,LF_support,\
RF_grip_x,RF_grip_y,RF_grip_z,RF_planted,RF_support,\
LH_grip_x,LH_grip_y,LH_grip_z,LH_planted,LH_support,\
RH_grip_x,RH_grip_y,RH_grip_z,RH_planted,RH_support,\
support_kind";

/// Streams rows into a temporary file; [`TrajectoryCsv::finish`] renames it
/// into place. The first write error is kept and returned by `finish`.
#[derive(Debug)]
pub struct TrajectoryCsv {
    file: AtomicFile,
    error: Option<std::io::Error>,
    rows: u64,
}

impl TrajectoryCsv {
    /// Creates the file (under a temporary name) and writes the header.
    ///
    /// # Errors
    /// [`ExportError::Io`] when the folder is not writable.
    pub fn create(path: &Path) -> Result<Self, ExportError> {
        let mut file = AtomicFile::create(path)?;
        let error = writeln!(file, "{CSV_HEADER}").err();
        Ok(Self {
            file,
            error,
            rows: 0,
        })
    }

    /// Appends one row.
    pub fn row(&mut self, s: &Sample) {
        if self.error.is_some() {
            return;
        }
        let r = write_row(self.file.writer(), s);
        self.rows += 1;
        if let Err(e) = r {
            self.error = Some(e);
        }
    }

    /// Rows written.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Flushes and renames into place.
    ///
    /// # Errors
    /// The first write error (the temporary file is removed).
    pub fn finish(self) -> Result<(), ExportError> {
        if let Some(e) = self.error {
            return Err(self.file.error(e));
        }
        self.file.commit()
    }
}

/// `v` with `decimals` decimals, as `{:.N}` prints it, through integer
/// formatting (float formatting was 70 % of the sampling cost of a
/// 2,000-sloth recording).
fn fixed(w: &mut impl Write, v: f32, decimals: u32) -> std::io::Result<()> {
    let scale = 10i64.pow(decimals);
    let x = (f64::from(v) * scale as f64).round_ties_even();
    if !x.is_finite() || x.abs() >= 9e15 {
        return write!(w, "{v:.*}", decimals as usize);
    }
    let x = x as i64;
    let sign = if x < 0 { "-" } else { "" };
    let (int, frac) = (x.abs() / scale, x.abs() % scale);
    write!(w, "{sign}{int}.{frac:0width$}", width = decimals as usize)
}

fn write_row(w: &mut impl Write, s: &Sample) -> std::io::Result<()> {
    let (p, q) = (s.body_pos, s.body_rot);
    fixed(w, s.t, 6)?;
    write!(w, ",{}", s.id)?;
    for v in [p.x, p.y, p.z] {
        w.write_all(b",")?;
        fixed(w, v, 6)?;
    }
    for v in [q.x, q.y, q.z, q.w] {
        w.write_all(b",")?;
        fixed(w, v, 7)?;
    }
    for l in &s.limbs {
        for v in [l.grip.x, l.grip.y, l.grip.z] {
            w.write_all(b",")?;
            fixed(w, v, 6)?;
        }
        write!(w, ",{},{}", u8::from(l.planted), l.support)?;
    }
    writeln!(w, ",{}", s.support_kind)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::LimbSample;
    use glam::{Quat, Vec3};

    #[test]
    fn fixed_point_prints_as_float_formatting() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for k in 0..20_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let v = f32::from_bits(state as u32);
            let v = if v.is_finite() && v.abs() < 1e4 {
                v
            } else {
                k as f32 * -0.37
            };
            for d in [6, 7] {
                let mut a = Vec::new();
                fixed(&mut a, v, d).unwrap();
                let a = String::from_utf8(a).unwrap();
                let b = format!("{v:.*}", d as usize);
                // Both round the same value; ties may round apart in the last digit.
                let (x, y): (f64, f64) = (a.parse().unwrap(), b.parse().unwrap());
                assert!(
                    (x - y).abs() <= 1.01 * 10f64.powi(-(d as i32)),
                    "{v}: {a} vs {b}"
                );
                // Only the sign of a zero differs (`{:.6}` prints -0.000000).
                assert!(
                    a.len() == b.len() || b.starts_with("-0.0"),
                    "{v}: {a} vs {b}"
                );
            }
        }
        for (v, want) in [
            (-0.25f32, "-0.250000"),
            (0.0, "0.000000"),
            (-3.5e-7, "0.000000"),
            (1.5, "1.500000"),
            (-12.345678, "-12.345678"),
        ] {
            let mut a = Vec::new();
            fixed(&mut a, v, 6).unwrap();
            assert_eq!(String::from_utf8(a).unwrap(), want, "{v}");
        }
    }

    #[test]
    fn rows_match_the_header() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("trajectories.csv");
        let mut csv = TrajectoryCsv::create(&path).unwrap();
        let limb = LimbSample {
            grip: Vec3::new(1.0, 2.0, 3.0),
            planted: true,
            support: 4,
        };
        csv.row(&Sample {
            t: 0.5,
            id: 3,
            body_pos: Vec3::ONE,
            body_rot: Quat::IDENTITY,
            joints: vec![],
            limbs: [limb; 4],
            support_kind: "trunk",
        });
        csv.finish().unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 2);
        assert_eq!(
            lines[0].split(',').count(),
            lines[1].split(',').count(),
            "{text}"
        );
        assert!(lines[1].starts_with("0.500000,3,1.000000"));
        assert!(lines[1].ends_with(",1,4,trunk"));
    }
}
