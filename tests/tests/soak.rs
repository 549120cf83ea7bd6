//! A short soak: `lander bench --stress --soak` flies the churn workload
//! round after round for 30 s while workers are killed twice a second, and
//! the coordinator's memory, open descriptors and iceoryx2 files must not
//! grow past the stated bounds; every result must equal in-process. The
//! 10-minute run is in docs/reliability.md.

use lander_tests::{stderr, Iox};
use serde_json::Value;

#[test]
fn thirty_seconds_of_churn_leak_nothing_and_lose_nothing() {
    let iox = Iox::new("soak");
    let out = iox.lander(&[
        "bench",
        "--stress",
        "--soak",
        "30",
        "--population",
        "2000",
        "--generations",
        "10",
        "--json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report: Value = serde_json::from_slice(&out.stdout).expect("--json prints JSON");
    assert_eq!(report["results_match"], true, "{report}");
    assert_eq!(report["evaluated"], report["expected"], "{report}");
    assert!(report["kills"].as_u64().unwrap_or(0) >= 20, "{report}");
    let soak = &report["soak"];
    assert!(soak["rounds"].as_u64().unwrap_or(0) >= 2, "{report}");
    assert!(soak["seconds"].as_f64().unwrap_or(0.0) >= 30.0, "{report}");
    for key in ["resident_kib", "open_descriptors", "iceoryx2_files"] {
        let (start, end, bound) = (
            soak["start"][key].as_u64().unwrap(),
            soak["end"][key].as_u64().unwrap(),
            soak["bounds"][key].as_u64().unwrap(),
        );
        assert!(start > 0 || key == "iceoryx2_files", "{key}: {report}");
        assert!(end.saturating_sub(start) <= bound, "{key} grew: {report}");
    }
}
