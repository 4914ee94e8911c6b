//! `hil soak`: a long run with nothing lost. In process ([`inproc`]): one `Runtime`
//! over the simulated link for hours of simulated service, streamed, checked at every
//! tick. The free-running firmware under QEMU ([`qemu`]): minutes of real time.

pub mod inproc;
pub mod line;
pub mod qemu;
pub mod service;
