//! The wire protocol between the plant simulator (host) and the controller (device),
//! `no_std`: the only definition of the format.
#![no_std]
