//! Forest scene: supports, presets, glTF, traces.
