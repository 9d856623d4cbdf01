use super::*;
use crate::scene::mitsuba::xml;

/// `body` in a scene file of `version` (`None`: no version attribute), read and
/// upgraded: the scene element and the upgrade's warnings.
fn read(version: Option<&str>, body: &str) -> crate::scene::error::Result<(Node, Vec<String>)> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.xml");
    let attr = version.map_or(String::new(), |v| format!(" version=\"{v}\""));
    std::fs::write(&path, format!("<scene{attr}>\n{body}\n</scene>\n")).unwrap();
    xml::read(&path).map(|r| (r.root, r.warnings))
}

/// `body` in a 0.6 file, upgraded.
fn upgraded(body: &str) -> (Node, Vec<String>) {
    read(Some("0.6.0"), body).unwrap_or_else(|e| panic!("{e}"))
}

/// The error upgrading `body` in a 0.6 file.
fn upgrade_error(body: &str) -> String {
    match read(Some("0.6.0"), body) {
        Ok(_) => panic!("upgraded: {body}"),
        Err(e) => e.to_string(),
    }
}

/// The first element with tag `tag`, depth first.
fn find<'a>(n: &'a Node, tag: &str) -> &'a Node {
    fn walk<'a>(n: &'a Node, tag: &str) -> Option<&'a Node> {
        if n.tag == tag {
            return Some(n);
        }
        n.children.iter().find_map(|c| walk(c, tag))
    }
    walk(n, tag).unwrap_or_else(|| panic!("no <{tag}>"))
}

/// Each child as `tag name=value` (or `tag` and its attributes).
fn params(n: &Node) -> Vec<String> {
    let mut out: Vec<String> = (n.children.iter())
        .map(|c| match (c.attr("name"), c.attr("value")) {
            (Some(k), Some(v)) => format!("{} {k}={v}", c.tag),
            _ => {
                let attrs: Vec<String> = c.attrs.iter().map(|(k, v)| format!("{k}={v}")).collect();
                format!("{} {}", c.tag, attrs.join(" "))
            }
        })
        .collect();
    out.sort();
    out
}

#[test]
fn names_become_snake_case_as_mitsuba_3_converts_them() {
    let cases = [
        ("toWorld", "to_world"),
        ("maxDepth", "max_depth"),
        ("intIOR", "int_ior"),
        ("specularReflectance", "specular_reflectance"),
        ("alphaU", "alpha_u"),
        ("aBcD", "a_bc_d"),
        ("useGridBBox", "use_grid_bbox"),
        ("already_snake", "already_snake"),
        ("B", "B"),
        ("color0", "color0"),
    ];
    for (camel, snake) in cases {
        assert_eq!(snake_case(camel), snake, "{camel}");
    }
}

#[test]
fn versions_below_2_are_legacy() {
    assert_eq!(is_legacy("0.6.0"), Some(true));
    assert_eq!(is_legacy("0.5"), Some(true));
    assert_eq!(is_legacy("3.0.0"), Some(false));
    assert_eq!(is_legacy("2.1.0"), Some(false));
    assert_eq!(is_legacy("three"), None);
    assert_eq!(is_legacy("0.6.0.1"), None);
}

#[test]
fn a_file_without_a_version_is_upgraded_and_a_mitsuba_3_file_is_not() {
    let body = "<integrator type=\"path\"><integer name=\"maxDepth\" value=\"3\"/></integrator>";
    let (root, _) = read(None, body).unwrap();
    assert_eq!(params(find(&root, "integrator")), ["integer max_depth=3"]);
    let (root, _) = read(Some("3.0.0"), body).unwrap();
    assert_eq!(params(find(&root, "integrator")), ["integer maxDepth=3"]);
    let err = read(Some("zero.six"), body).unwrap_err().to_string();
    assert!(
        err.starts_with("s.xml:1:1: <scene>: version \"zero.six\""),
        "{err}"
    );
}

#[test]
fn mitsuba_3s_own_upgrade_renames_and_builds_to_uv_offset_first() {
    let (root, w) = upgraded(
        "<bsdf type=\"diffuse\">\n\
         <texture type=\"checkerboard\" name=\"diffuseReflectance\">\n\
         <float name=\"uoffset\" value=\"0.5\"/><float name=\"uscale\" value=\"2\"/>\n\
         <float name=\"vscale\" value=\"3\"/>\n\
         </texture></bsdf>",
    );
    let tex = find(&root, "texture");
    assert_eq!(tex.attr("name"), Some("reflectance"));
    let to_uv = find(tex, "transform");
    assert_eq!(to_uv.attr("name"), Some("to_uv"));
    // Mitsuba 3 left-multiplies: uv' = scale * (uv + offset).
    let steps: Vec<String> = (to_uv.children.iter())
        .map(|c| {
            format!(
                "{} {} {}",
                c.tag,
                c.attr("x").unwrap(),
                c.attr("y").unwrap()
            )
        })
        .collect();
    assert_eq!(steps, ["translate 0.5 0", "scale 2 3"]);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].starts_with("s.xml:3:1: <texture type=\"checkerboard\" name=\"diffuse_reflectance\">: uoffset/voffset with uscale/vscale: Mitsuba 0.x scaled"), "{}", w[0]);
    // A scale alone means the same in both orders: no warning, no translate.
    let (root, w) =
        upgraded("<texture type=\"checkerboard\"><float name=\"uscale\" value=\"4\"/></texture>");
    assert!(w.is_empty(), "{w:?}");
    assert_eq!(params(find(&root, "transform")), ["scale x=4 y=1"]);
}

#[test]
fn the_0x_value_forms_become_mitsuba_3s() {
    let (root, _) = upgraded(
        "<shape type=\"sphere\"><transform name=\"toWorld\">\
         <lookAt origin=\"0, 0, 1\" target=\"0, 0, 0\"/></transform>\
         <bsdf type=\"diffuse\"><srgb name=\"reflectance\" value=\"#808080\"/></bsdf>\
         <emitter type=\"area\"><rgb name=\"radiance\" value=\"#ff8000\" intent=\"illuminant\"/>\
         </emitter></shape>",
    );
    assert_eq!(find(&root, "transform").children[0].tag, "lookat");
    let grey = crate::film::srgb_eotf(128.0 / 255.0);
    assert_eq!(
        params(find(&root, "bsdf")),
        [format!("rgb reflectance={grey}, {grey}, {grey}")]
    );
    let light = find(&root, "emitter");
    assert_eq!(
        params(light),
        [format!("rgb radiance=1, {}, 0", 128.0 / 255.0)]
    );
    assert_eq!(light.children[0].attrs.len(), 2, "intent dropped");
    for (body, words) in [
        (
            "<rgb name=\"c\" value=\"#12345\"/>",
            "not a colour of the form #rrggbb",
        ),
        (
            "<srgb name=\"c\" value=\"400:0.1, 700:0.2\"/>",
            "spectra given by wavelength",
        ),
        (
            "<blackbody name=\"c\" temperature=\"5000\"/>",
            "black-body spectra",
        ),
        (
            "<transform name=\"toWorld\"><animation/></transform>",
            "animated transforms",
        ),
        (
            "<subsurface type=\"dipole\"/>",
            "subsurface integrators (dipole)",
        ),
        (
            "<alias id=\"a\" as=\"b\"/>",
            "<alias> has no Mitsuba 3 form",
        ),
    ] {
        let err = upgrade_error(&format!("<emitter type=\"point\">\n{body}\n</emitter>"));
        assert!(err.starts_with("s.xml:3:"), "{err}");
        assert!(err.contains(words), "{err}");
    }
}

#[test]
fn bitmaps_get_one_wrap_mode_bilinear_filtering_and_raw_for_gamma_1() {
    let (root, w) = upgraded(
        "<texture type=\"bitmap\">\n\
         <string name=\"filename\" value=\"a.png\"/>\
         <string name=\"wrapModeU\" value=\"mirror\"/><string name=\"wrapModeV\" value=\"mirror\"/>\
         <float name=\"gamma\" value=\"1\"/><float name=\"maxAnisotropy\" value=\"8\"/>\
         <boolean name=\"cache\" value=\"false\"/></texture>",
    );
    assert_eq!(
        params(find(&root, "texture")),
        [
            "boolean raw=true",
            "string filename=a.png",
            "string wrap_mode=mirror"
        ]
    );
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("Mitsuba 0.x filtered this texture (ewa"),
        "{}",
        w[0]
    );
    let (root, w) = upgraded(
        "<texture type=\"bitmap\"><string name=\"filterType\" value=\"nearest\"/>\
         <string name=\"wrapMode\" value=\"clamp\"/><float name=\"gamma\" value=\"2.2\"/></texture>",
    );
    assert_eq!(
        params(find(&root, "texture")),
        ["string filter_type=nearest", "string wrap_mode=clamp"]
    );
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("gamma 2.2: decoded with the sRGB curve"),
        "{}",
        w[0]
    );
    let err = upgrade_error(
        "<texture type=\"bitmap\">\n<string name=\"wrapMode\" value=\"zero\"/></texture>",
    );
    assert!(
        err.starts_with("s.xml:3:1: <string name=\"wrap_mode\">: wrap mode \"zero\""),
        "{err}"
    );
    let err = upgrade_error(
        "<texture type=\"bitmap\"><string name=\"wrapModeU\" value=\"clamp\"/></texture>",
    );
    assert!(
        err.contains("wrap mode clamp in u and repeat in v"),
        "{err}"
    );
}

#[test]
fn films_and_sensors_take_their_mitsuba_3_parameters() {
    let (root, w) = upgraded(
        "<sensor type=\"perspective\">\
         <float name=\"shutterOpen\" value=\"0.5\"/><float name=\"shutterOpenTime\" value=\"1\"/>\
         <film type=\"ldrfilm\">\
         <float name=\"exposure\" value=\"1\"/><string name=\"tonemapMethod\" value=\"reinhard\"/>\
         <float name=\"key\" value=\"0.2\"/><boolean name=\"highQualityEdges\" value=\"true\"/>\
         <boolean name=\"attachLog\" value=\"true\"/></film></sensor>",
    );
    let sensor = find(&root, "sensor");
    assert_eq!(
        params(sensor),
        [
            "film type=hdrfilm",
            "float shutter_close=1.5",
            "float shutter_open=0.5"
        ]
    );
    assert_eq!(params(find(sensor, "film")), ["boolean sample_border=true"]);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("tonemap_method reinhard, exposure 1 is not applied"),
        "{}",
        w[0]
    );
}

#[test]
fn homogeneous_media_get_sigma_t_and_albedo_with_0xs_skin1_defaults() {
    let medium = |body: &str| {
        let (root, _) = upgraded(&format!("<medium type=\"homogeneous\">{body}</medium>"));
        params(find(&root, "medium"))
    };
    assert_eq!(
        medium("<rgb name=\"sigmaA\" value=\"1, 2, 0\"/><float name=\"sigmaS\" value=\"1\"/>"),
        [
            "rgb albedo=0.5, 0.3333333333333333, 1",
            "rgb sigma_t=2, 3, 1"
        ]
    );
    // Mitsuba 0.x fills what is missing from its default preset, Skin1.
    assert_eq!(
        medium("<float name=\"sigmaA\" value=\"0\"/><string name=\"strategy\" value=\"single\"/>"),
        ["rgb albedo=1, 1, 1", "rgb sigma_t=74, 88, 101"]
    );
    let skin = medium("<float name=\"sigmaT\" value=\"2\"/>");
    assert_eq!(skin[0], "float sigma_t=2");
    assert_eq!(
        skin[1],
        format!(
            "rgb albedo={}, {}, {}",
            74.0 / (3.2 + 74.0),
            88.0 / 105.0,
            101.0 / 149.0
        )
    );
    let err = upgrade_error(
        "<medium type=\"homogeneous\">\n<string name=\"material\" value=\"Ketchup\"/></medium>",
    );
    assert!(
        err.starts_with("s.xml:3:1: <string name=\"material\">: measured material presets"),
        "{err}"
    );
    let err = upgrade_error("<medium type=\"homogeneous\"><float name=\"sigmaA\" value=\"1\"/><float name=\"albedo\" value=\"1\"/></medium>");
    assert!(err.contains("not a mix"), "{err}");
}

#[test]
fn options_that_only_change_the_noise_are_dropped() {
    let (root, w) = upgraded(
        "<emitter type=\"envmap\"><string name=\"filename\" value=\"a.exr\"/>\
         <float name=\"samplingWeight\" value=\"2\"/><boolean name=\"cache\" value=\"true\"/></emitter>\
         <medium type=\"heterogeneous\"><string name=\"method\" value=\"simpson\"/>\
         <float name=\"stepSize\" value=\"0.1\"/></medium>",
    );
    assert_eq!(params(find(&root, "emitter")), ["string filename=a.exr"]);
    assert!(params(find(&root, "medium")).is_empty());
    assert!(w.is_empty(), "{w:?}");
}
