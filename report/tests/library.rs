//! `robosim report library`, quick.

#[test]
fn bench_quick_writes_the_report() {
    let dir = tempfile::tempdir().expect("tmp");
    let files = robosim_report::library::report_library(dir.path(), true).expect("report");
    assert!(
        files
            .iter()
            .any(|f| f.extension().is_some_and(|e| e == "csv"))
    );
    let csv = std::fs::read_to_string(dir.path().join("library.csv")).expect("csv");
    assert_eq!(csv.lines().count(), 5, "{csv}");
}
