//! Sloth rig: skeleton, FK, CCD IK.
