//! The transport trait every target implements: defined once, beside the simulated link
//! and the in-process device in `sim_host::transport` (the plant's own device loop uses
//! it too); re-exported here for the harness's targets (QEMU, serial).

pub use sim_host::transport::{Accounting, Clock, LinkAccounting, Transport, TransportError};
