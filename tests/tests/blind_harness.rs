//! The blind harness's own lists (`tests/src/blind.rs`): its catalogue is the CLI's, and a
//! miss's search with the truth's entries alone leaves out exactly what the plant does not
//! hold.

use motor_id_shared::model::effects::CATALOGUE;
use motor_id_tests::blind::{all_but_the_truth, catalogue};
use std::collections::BTreeSet;

#[test]
fn the_harness_s_catalogue_is_the_cli_s() {
    let harness = catalogue();
    let distinct: BTreeSet<&str> = harness.iter().copied().collect();
    assert_eq!(distinct.len(), harness.len(), "an entry twice: {harness:?}");
    let cli: BTreeSet<&str> = CATALOGUE.iter().map(|spec| spec.name).collect();
    assert_eq!(distinct, cli);
}

#[test]
fn a_search_of_the_truth_alone_leaves_out_every_entry_the_plant_does_not_hold() {
    // Static friction comes with its Coulomb friction; a withheld effect has no entry.
    let without = all_but_the_truth(&["static", "cogging-untold"]);
    assert_eq!(without.len(), CATALOGUE.len() - 2);
    for kept in ["static_friction", "coulomb_friction"] {
        assert!(!without.contains(&kept), "{kept} left out");
    }
    for left in [
        "asymmetric_friction",
        "cogging",
        "sensor_delay",
        "quadratic_load",
    ] {
        assert!(without.contains(&left), "{left} kept");
    }
    let without = all_but_the_truth(&["limit", "delay"]);
    assert_eq!(without.len(), CATALOGUE.len() - 2);
    assert!(!without.contains(&"current_limit") && !without.contains(&"sensor_delay"));
}
