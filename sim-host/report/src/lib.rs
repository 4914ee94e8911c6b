//! What every report of the workspace is made of, with no dependency of the workspace.
//!
//! - [`svg`]: a small dependency-free SVG plotting module (line, scatter, bars, heat maps).
//! - [`out`](mod@out): the command lines' standard output ([`outln!`], [`out!`]), quiet on a
//!   closed pipe.
#![deny(missing_docs)]

pub mod out;
pub mod svg;
