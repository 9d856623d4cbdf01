//! sppm's state and checkpoints.

use super::state::{PIXEL_BYTES, STATE_HEAD};
use super::*;

#[test]
fn state_round_trips_and_rejects_damage() {
    let mut st = State::new(9, 4, 3, 0.25);
    st.passes = 4;
    st.emitted = 1234;
    st.pixels[1].tau = [1.0, 2.0, 3.5];
    st.pixels[2].n = 17.3;
    let bytes = st.encode(Variant::Sppm);
    assert_eq!(State::decode(&bytes, Variant::Sppm).unwrap(), st);
    assert!(matches!(
        State::decode(&bytes, Variant::Ppm),
        Err(StateError::Variant { .. })
    ));
    assert!(matches!(
        State::decode(&bytes[..bytes.len() - 1], Variant::Sppm),
        Err(StateError::Length(_))
    ));
    let mut bad = bytes.clone();
    bad[0] = b'X';
    assert!(matches!(
        State::decode(&bad, Variant::Sppm),
        Err(StateError::Magic)
    ));
    let mut nan = bytes;
    let o = STATE_HEAD + PIXEL_BYTES; // pixel 1, N
    nan[o..o + 8].copy_from_slice(&f64::NAN.to_le_bytes());
    assert!(matches!(
        State::decode(&nan, Variant::Sppm),
        Err(StateError::Value(1))
    ));
}

#[test]
fn settings_validate() {
    assert!(SppmSettings::default().validate().is_ok());
    for bad in [
        SppmSettings {
            alpha: 0.0,
            ..Default::default()
        },
        SppmSettings {
            light_paths: 0.0,
            ..Default::default()
        },
        SppmSettings {
            radius: Some(-1.0),
            ..Default::default()
        },
        SppmSettings {
            max_depth: 0,
            ..Default::default()
        },
    ] {
        assert!(bad.validate().is_err(), "{bad:?}");
    }
}
