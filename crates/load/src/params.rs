//! Parameters of the grip-load model (see the crate README for their reasoning).

use crate::LoadError;

/// Body and contact parameters plus the objective's weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadParams {
    /// Body mass (kg). SPEC: 6.5–10.6 kg; default 8 kg.
    pub mass_kg: f64,
    /// Gravitational acceleration (m/s², acting along −Y).
    pub gravity: f64,
    /// Friction coefficient of claw and pad on the support (Coulomb, tangential ≤ µ × normal).
    pub mu: f64,
    /// Grip strength of one limb: the largest pull toward the support's axis its hooked
    /// claws hold, in body weights (default 1.0: a sloth hangs from a single limb).
    pub grip_strength_bw: f64,
    /// Push strength of one limb: the largest force pressing into the support, in body
    /// weights (default 1.0). Bounds the squeeze two limbs could otherwise exert on a
    /// branch between them to gain friction without limit.
    pub push_strength_bw: f64,
    /// Weight of the squared residual wrench (force in BW, torque in BW × `residual_arm_m`).
    pub w_residual: f64,
    /// Weight of the squared grip forces (BW²).
    pub w_force: f64,
    /// Length that turns a residual torque into a force (N·m → N): the torque equals that
    /// force applied this far from the centre of mass (default 0.2 m ≈ CoM to a girdle).
    pub residual_arm_m: f64,
}

impl Default for LoadParams {
    fn default() -> Self {
        Self {
            mass_kg: 8.0,
            gravity: 9.81,
            mu: 0.6,
            grip_strength_bw: 1.0,
            push_strength_bw: 1.0,
            w_residual: 1.0e4,
            w_force: 1.0,
            residual_arm_m: 0.2,
        }
    }
}

impl LoadParams {
    /// Check every parameter is finite and positive; the error names the field.
    pub fn validate(&self) -> Result<(), LoadError> {
        let fields = [
            ("mass_kg", self.mass_kg),
            ("gravity", self.gravity),
            ("mu", self.mu),
            ("grip_strength_bw", self.grip_strength_bw),
            ("push_strength_bw", self.push_strength_bw),
            ("w_residual", self.w_residual),
            ("w_force", self.w_force),
            ("residual_arm_m", self.residual_arm_m),
        ];
        for (field, value) in fields {
            if !value.is_finite() || value <= 0.0 {
                return Err(LoadError::InvalidParam { field, value });
            }
        }
        Ok(())
    }

    /// Body weight m·g (N).
    pub fn body_weight_n(&self) -> f64 {
        self.mass_kg * self.gravity
    }
}
