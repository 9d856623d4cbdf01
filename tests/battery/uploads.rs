//! Issue 36's hostile uploads: an import whose work multiplies (an include tree of
//! 2^30 includes, a twosided BSDF that names itself, which overflowed the stack and
//! aborted the server), a `serialized` offset of 2^64 - 2, an integrator section no
//! job could run with, and a bundle padded with files its scene does not name.

use super::*;

/// Long enough for a loaded machine; the include tree took hours before.
const QUICK: Duration = Duration::from_secs(30);

fn tar_of(files: &[(String, Vec<u8>)]) -> Vec<u8> {
    let entries: Vec<(&str, &[u8])> = files
        .iter()
        .map(|(n, d)| (n.as_str(), d.as_slice()))
        .collect();
    server_common::tar_with(&entries)
}

/// A Mitsuba fixture's bytes.
fn fixture(name: &str) -> Vec<u8> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mitsuba");
    std::fs::read(dir.join(name)).unwrap()
}

/// `tri.serialized` with a second shape at byte 2^64 - 2 (which wrapped to byte 2).
fn serialized_past_the_end() -> Vec<u8> {
    let mut bytes = fixture("meshes/tri.serialized");
    bytes.truncate(bytes.len() - 12);
    for offset in [0, u64::MAX - 1] {
        bytes.extend(offset.to_le_bytes());
    }
    bytes.extend(2u32.to_le_bytes());
    bytes
}

fn importer_cases() -> Vec<Case> {
    let tree: Vec<(String, Vec<u8>)> = (server_common::include_tree().into_iter())
        .map(|(n, t)| (n, t.into_bytes()))
        .collect();
    let selfish =
        "<scene version=\"3.0.0\"><bsdf type=\"twosided\" id=\"b\"><ref id=\"b\"/></bsdf>\
                   <shape type=\"sphere\"><ref id=\"b\"/></shape></scene>";
    let serialized = vec![
        (
            "scene.xml".to_string(),
            b"<scene version=\"3.0.0\"><shape type=\"serialized\">\
              <string name=\"filename\" value=\"m.serialized\"/>\
              <integer name=\"shape_index\" value=\"1\"/></shape></scene>"
                .to_vec(),
        ),
        ("m.serialized".to_string(), serialized_past_the_end()),
    ];
    let mut deep = tiny_scene(8);
    deep["integrator"] = json!({"algorithm": "pt", "max_depth": 1u64 << 32});
    vec![
        case(
            "xml: an include tree of 2^30 includes",
            upload(tar_of(&tree)),
            &[422],
        )
        .mentions("<include>s")
        .within(QUICK),
        case(
            "xml: a twosided bsdf that names itself",
            upload(selfish),
            &[422],
        )
        .mentions("refers to itself"),
        case(
            "xml: a serialized shape at byte 2^64 - 2",
            upload(tar_of(&serialized)),
            &[422],
        )
        .mentions("m.serialized"),
        case(
            "scene: integrator max_depth 2^32",
            upload(deep.to_string()),
            &[422],
        )
        .mentions("integrator.max_depth"),
    ]
}

/// A megabyte of padding beside a scene: stored before, now dropped and named.
fn padding_is_not_stored(b: &mut Battery) {
    let padding = vec![0u8; 1 << 20];
    let bundle = tar(&[
        file("scene.json", tiny_scene(8).to_string().as_bytes()),
        file("padding.bin", &padding),
    ]);
    let what = "tar: a scene and a megabyte of padding";
    let Some(r) = b.run(case(what, upload(bundle), &[201])) else {
        return;
    };
    let info = r.json().unwrap_or_default();
    let size = info["size_bytes"].as_u64().unwrap_or(u64::MAX);
    if size >= 1 << 20 || !info["warnings"].to_string().contains("padding.bin") {
        b.fail(format!("{what}: the padding was kept or not named: {info}"));
    }
}

/// Issue 36's upload cases, against the main server.
pub(super) fn run(b: &mut Battery) {
    b.run_all(importer_cases());
    padding_is_not_stored(b);
}
