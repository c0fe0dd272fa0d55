//! The IK report writes its three files (quick mode; timings are not asserted).

#[test]
fn report_ik_quick_writes_csv_markdown_and_png() {
    let dir = tempfile::tempdir().expect("temp dir");
    let paths = robosim_report::ik::report_ik(dir.path(), true).expect("report written");
    assert_eq!(paths.len(), 3);
    let csv = std::fs::read_to_string(dir.path().join("ik.csv")).expect("csv");
    let header = csv.lines().next().expect("header");
    assert!(
        header.starts_with("robot,method,tolerance,poses,success_pct,mean_us,median_us,p99_us")
    );
    // 5 closed-form/hybrid rows + 2 robots × 4 tolerances × 3 numeric methods.
    assert_eq!(csv.lines().count(), 1 + 5 + 24);
    for line in csv.lines().skip(1) {
        let success: f64 = line
            .split(',')
            .nth(4)
            .and_then(|s| s.parse().ok())
            .expect("success_pct");
        assert!(success > 90.0, "{line}");
    }
    assert!(dir.path().join("ik.png").metadata().expect("png").len() > 1000);
}
