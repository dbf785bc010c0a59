//! Asset generators for slothsim (offline code: nothing here runs in the simulation).

pub mod rig_asset;
