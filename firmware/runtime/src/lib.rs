//! The device runtime, `no_std` and board independent: frame handling, the fault
//! policy and the control tick. The board binaries and the host's in-process device
//! run this same code.
#![no_std]
