//! The figures the README and the book show (`docs/figures/*.svg`, drawn by the
//! commands of `cargo xtask readme`) pass the layout lint: no label over another or off
//! the canvas, no data beyond a panel's axes without a clipping mark.

use wheelset_report::svg::lint;

#[test]
fn the_books_figures_have_no_overlapping_label_and_no_unmarked_clipping() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/figures");
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).expect("docs/figures") {
        let path = entry.expect("entry").path();
        if path.extension().is_none_or(|e| e != "svg") {
            continue;
        }
        let svg = std::fs::read_to_string(&path).expect("read");
        let problems = lint::problems(&svg);
        assert!(problems.is_empty(), "{}: {problems:#?}", path.display());
        seen += 1;
    }
    assert!(seen >= 5, "only {seen} figures in {}", dir.display());
}
