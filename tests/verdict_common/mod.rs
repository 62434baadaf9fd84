//! The verdict must follow from the evidence recorded beside it in `results.json`: a check that any
//! study's diagnosis can be put through, whatever its data say.

use serde_json::Value;

/// The diagnosis's decision rule, read back from the numbers it reports (α = 0.01).
#[track_caller]
pub fn assert_verdict_follows_evidence(d: &Value) {
    const ALPHA: f64 = 0.01;
    let verdict = d["verdict"].as_str().expect("a verdict");
    let candidates = d["candidates"].as_array().expect("candidates");
    let k = candidates.len().max(1) as f64;
    let explains = |c: &Value| c["p_value"].as_f64().is_some_and(|p| p * k < ALPHA);
    for c in candidates {
        assert_eq!(
            c["explains_misfit"].as_bool(),
            Some(explains(c)),
            "explains_misfit of {c}"
        );
    }
    let lof_rejects = d["lack_of_fit"]["p_value"].as_f64().is_some_and(|p| p < ALPHA);
    let any_explains = candidates.iter().any(explains);
    let rivals = d["rivals"].as_array().expect("rivals");
    let bound = ALPHA / rivals.len().max(1) as f64;
    let ext_rejects = d["extended"]["lack_of_fit_p"].as_f64().is_some_and(|p| p < ALPHA)
        || rivals
            .iter()
            .any(|r| r["p_rival_given_leader"].as_f64().is_some_and(|p| p < bound));
    assert_eq!(
        d["discrepancy_detected"].as_bool(),
        Some(any_explains || lof_rejects),
        "{verdict}"
    );
    match verdict {
        "cause_named" => {
            let cause = d["cause"].as_str().expect("a cause");
            let leader = candidates.iter().find(|c| explains(c)).expect("a significant leader");
            assert_eq!(
                leader["name"], cause,
                "the cause is the best-ranked significant candidate"
            );
            for r in rivals {
                assert!(r["beaten"].as_bool().unwrap(), "cause named, yet a rival survives: {r}");
                if let Some(p) = r["p_leader_given_rival"].as_f64() {
                    assert!(p < ALPHA, "{r}");
                }
            }
            assert!(
                !ext_rejects,
                "the extended model misses the tests, yet the cause is called the whole story"
            );
        }
        "cannot_tell_apart" => {
            assert!(d["cause"].is_null());
            assert!(any_explains);
            assert!(
                rivals.iter().any(|r| !r["beaten"].as_bool().unwrap()),
                "no rival survives"
            );
            assert!(d["leading"].as_array().unwrap().len() >= 2);
        }
        "partly_explained" => {
            assert!(d["cause"].is_string());
            assert!(
                ext_rejects,
                "partly explained, yet the extended model fits and no rival adds to it"
            );
        }
        "no_model_error" => {
            assert!(!any_explains && !lof_rejects);
            assert!(d["cause"].is_null());
        }
        "unexplained" => assert!(lof_rejects && !any_explains && d["cause"].is_null()),
        "too_few_tests" => assert!(d["cause"].is_null()),
        other => panic!("unknown verdict {other}"),
    }
    assert!(d["next_test"].is_object(), "no next test: {}", d["summary"]);
    let words = d["headline"].as_str().unwrap().to_lowercase();
    let expected = match verdict {
        "cause_named" => "model error: cause named",
        "cannot_tell_apart" => "model error: leading candidates, cannot tell apart",
        "partly_explained" => "model error: partly explained",
        "no_model_error" => "no model error beyond the noise",
        "unexplained" => "model error: no listed cause explains it",
        _ => "too few tests to tell",
    };
    assert!(
        words.starts_with(expected),
        "headline {words:?} does not start with {expected:?}"
    );
    assert!(
        d["summary"]
            .as_str()
            .unwrap()
            .starts_with(d["headline"].as_str().unwrap())
    );
}
