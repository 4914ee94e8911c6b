//! The pictures of the README and the book: every image a page shows is a file under
//! `docs/figures/` that one generated block's command draws ([`FIGURES`]); `readme`
//! copies each drawn file over its committed copy, `--check` compares them byte for byte.

use std::path::Path;

/// One committed figure (paths from the workspace root).
#[derive(Debug, Clone, Copy)]
pub struct Figure {
    /// The committed copy the pages reference, e.g. `docs/figures/low-adhesion.svg`.
    pub path: &'static str,
    /// The generated block (in [`super::BLOCKS`]) whose command draws it.
    pub block: &'static str,
    /// The file that command writes.
    pub made: &'static str,
}

/// [`Figure`] rows: `path, block, made;`.
macro_rules! figures {
    ($($path:literal, $block:literal, $made:literal;)*) => {
        &[$(Figure { path: $path, block: $block, made: $made }),*]
    };
}

/// Every figure the README and the book show.
pub const FIGURES: &[Figure] = figures![
    "docs/figures/curve-lateral.svg", "fig6-8", "out/fig6-8/lateral.svg";
    "docs/figures/curve-creep.svg", "fig6-8", "out/fig6-8/creep.svg";
    "docs/figures/modes-case-c.svg", "modes", "out/modes/modes_case_c.svg";
    "docs/figures/low-adhesion.svg", "low-adhesion-on", "out/low/adhesion.svg";
    "docs/figures/actuator-fault-monitor.svg", "actuator-fault", "out/af/monitor.svg";
];

/// After the blocks' commands ran from `root`: copies every drawn figure over its
/// committed copy, or with `check` compares them; the paths that differed.
pub fn sync(root: &Path, check: bool) -> Result<Vec<&'static str>, String> {
    let mut changed = Vec::new();
    for f in FIGURES {
        let made = root.join(f.made);
        let new = std::fs::read(&made).map_err(|e| {
            format!(
                "figure {}: block `{}` should have drawn {}: {e}",
                f.path,
                f.block,
                made.display()
            )
        })?;
        let path = root.join(f.path);
        let old = std::fs::read(&path).ok();
        if old.as_deref() == Some(new.as_slice()) {
            continue;
        }
        changed.push(f.path);
        if !check {
            std::fs::write(&path, &new)
                .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        }
    }
    Ok(changed)
}
