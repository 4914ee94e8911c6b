//! What every report of the workspace is made of, with no dependency of the workspace.
#![deny(missing_docs)]

pub mod out;
pub mod output;
pub mod stats;
pub mod svg;
pub mod table;
pub mod verdict;

pub use stats::Stats;
pub use verdict::Verdict;
