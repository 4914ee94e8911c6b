//! The plant simulator: the railway wheelset with its traction drive on a canted curve.

pub mod device;
pub mod link;
