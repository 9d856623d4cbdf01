//! The sampler's settings form: tagged by `type`, snake case, `nodes` defaulted and
//! range-checked with an error that names it.

use crate::integrator::many::vrl::Sampler;

#[test]
fn samplers_round_trip_and_default_their_nodes() {
    for s in super::SAMPLERS
        .into_iter()
        .chain([Sampler::JointAdvanced { nodes: 2 }])
    {
        let json = serde_json::to_string(&s).unwrap();
        assert_eq!(serde_json::from_str::<Sampler>(&json).unwrap(), s, "{json}");
    }
    let parse = |j: &str| serde_json::from_str::<Sampler>(j);
    assert_eq!(
        parse(r#"{"type":"joint_advanced"}"#).unwrap(),
        Sampler::JointAdvanced { nodes: 10 }
    );
    assert_eq!(
        parse(r#"{"type":"joint_advanced","nodes":64}"#).unwrap(),
        Sampler::JointAdvanced { nodes: 64 }
    );
    assert_eq!(
        parse(r#"{"type":"uniform_equiangular"}"#).unwrap(),
        Sampler::UniformEquiangular
    );
    assert_eq!(
        serde_json::to_string(&Sampler::JointSimple).unwrap(),
        r#"{"type":"joint_simple"}"#
    );
}

#[test]
fn bad_sampler_settings_are_refused_with_their_field() {
    let parse = |j: &str| serde_json::from_str::<Sampler>(j).unwrap_err().to_string();
    for n in [0, 1, 65] {
        let e = parse(&format!(r#"{{"type":"joint_advanced","nodes":{n}}}"#));
        assert!(e.contains("nodes must be in 2..=64"), "{e}");
    }
    assert!(parse(r#"{"type":"joint_advanced","node":3}"#).contains("unknown field"));
    assert!(parse(r#"{"type":"joint"}"#).contains("unknown variant"));
}
