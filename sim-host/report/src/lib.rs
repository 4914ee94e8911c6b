//! What every report of the workspace is made of, with no dependency of the workspace.
//!
//! - [`svg`]: a small dependency-free SVG plotting module (line, scatter, bars, heat maps).
//! - [`table`]: the one Markdown table writer of every report.
//! - [`verdict`]: the pass/warn/fail [`Verdict`] of a check.
//! - [`stats`]: the summary [`Stats`] of a sample (min, mean, p99, max).
//! - [`out`](mod@out): the command lines' standard output ([`outln!`], [`out!`]), quiet
//!   on a closed pipe.
//! - [`output`]: output paths checked before any work (exit 2 naming the flag).
#![deny(missing_docs)]

pub mod out;
pub mod output;
pub mod stats;
pub mod svg;
pub mod table;
pub mod verdict;

pub use stats::Stats;
pub use verdict::Verdict;
