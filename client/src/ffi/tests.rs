//! Tests of the C ABI's constants, status names and best sample.

use super::*;

#[test]
fn the_c_constants_are_the_protocols() {
    assert_eq!(CLIFF_METHOD_CLIFF, protocol::METHOD_CLIFF);
    assert_eq!(CLIFF_METHOD_CVM, protocol::METHOD_CVM);
    assert_eq!(CLIFF_METHOD_IMPROVED, protocol::METHOD_IMPROVED);
    assert_eq!(CLIFF_METHOD_MOTION, protocol::METHOD_MOTION);
    assert_eq!(CLIFF_METHOD_CVM_LAST, protocol::METHOD_CVM_LAST);
    assert_eq!(CLIFF_FLAG_SCORES, protocol::FLAG_SCORES);
    assert_eq!(CLIFF_FLAG_BASE_MAP, protocol::FLAG_BASE_MAP);
    assert_eq!(CLIFF_TIME_NOW, protocol::TIME_NOW);
    assert_eq!(CLIFF_TIME_AT, protocol::TIME_AT);
    assert_eq!(CLIFF_TIME_ALL_DAY, protocol::TIME_ALL_DAY);
}

#[test]
fn every_status_has_the_name_the_rust_side_gives_it() {
    for (c, s) in (0..).map_while(|c| Status::from_code(c).map(|s| (c, s))) {
        // SAFETY: cliff_status_name returns a static NUL-terminated string
        let name = unsafe { CStr::from_ptr(cliff_status_name(c)) };
        assert_eq!(name.to_str().unwrap(), s.name());
    }
}

#[test]
fn best_sample_reads_the_scores_of_one_agent() {
    let scores = [-3.0f32, -1.0, -2.0, -5.0, -4.0, -4.0];
    let mut p = CliffPrediction {
        request_id: 0,
        status: 0,
        agents: 2,
        k: 3,
        steps: 1,
        positions: ptr::null(),
        lens: ptr::null(),
        scores: scores.as_ptr(),
    };
    // SAFETY: scores holds agents * k floats
    unsafe {
        assert_eq!(cliff_prediction_best_sample(&p, 0), 1);
        assert_eq!(cliff_prediction_best_sample(&p, 1), 1); // the first of equals
        assert_eq!(cliff_prediction_best_sample(&p, 2), -1);
        assert_eq!(cliff_prediction_best_sample(ptr::null(), 0), -1);
        p.scores = ptr::null();
        assert_eq!(cliff_prediction_best_sample(&p, 0), -1);
    }
}
