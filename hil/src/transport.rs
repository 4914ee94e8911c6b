//! The transport trait every target implements: defined once, beside the simulated link
//! and the in-process device in `wheelset_loop::transport` (the plant's own device loop uses
//! it too); re-exported here for the harness's targets (QEMU, serial).

pub use wheelset_loop::transport::{Accounting, Clock, LinkAccounting, Transport, TransportError};
