//! The wheelset's control laws, `no_std`: discretised phase-lead yaw damping and the PI
//! traction current loop, generic over the sample type (f64, f32, fixed point).
#![no_std]
