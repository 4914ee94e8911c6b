//! What every report of the workspace is made of, with no dependency of the workspace:
//! SVG figures ([`svg`]), Markdown tables ([`table`]), the [`Verdict`] of a check, the
//! [`Stats`] of a sample, quiet standard output ([`out`](mod@out)) and output paths
//! checked before any work ([`output`]).
#![deny(missing_docs)]

pub mod out;
pub mod output;
pub mod stats;
pub mod svg;
pub mod table;
pub mod verdict;

pub use stats::Stats;
pub use verdict::Verdict;
