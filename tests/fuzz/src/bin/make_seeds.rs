//! Writes the seed corpora, one folder per target, from the repository's scenes and
//! small generated files: `make_seeds CORPUS_DIR` (run.sh's README tells when).
//! Seeds are kept to a few KiB: AFL mutates small inputs far faster.

use caustic::film::{encode_exr, Image};
use caustic::math::Vec3;
use caustic::medium::grid_io::{write_raw, write_vol, DenseGrid};
use exr::prelude::{self as x, AnyChannel, AnyChannels, FlatSamples, Layer, LayerAttributes};
use std::io::Write;
use std::path::{Path, PathBuf};

fn main() {
    let out = PathBuf::from(
        std::env::args()
            .nth(1)
            .expect("usage: make_seeds CORPUS_DIR"),
    );
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let scenes = scene_seeds(&repo);
    let mesh = [("quad.obj", QUAD_OBJ.as_bytes())];
    for (name, text) in &scenes {
        save(&out, "scene_json", name, text.as_bytes());
    }
    save(&out, "bundle", "tiny.json", TINY.as_bytes());
    let with_obj = TINY.replace(
        SPHERE,
        r#"{"type":"obj","filename":"quad.obj","material":"m"}"#,
    );
    save(&out, "bundle", "obj.tar", &tar(&with_obj, &mesh));
    save(&out, "bundle", "obj.zip", &zip(&with_obj, &mesh));
    let with_ply = TINY.replace(
        SPHERE,
        r#"{"type":"ply","filename":"t.ply","material":"m"}"#,
    );
    save(
        &out,
        "bundle",
        "ply.tar",
        &tar(&with_ply, &[("t.ply", PLY_ASCII.as_bytes())]),
    );
    for (name, bytes) in exr_seeds() {
        save(&out, "exr", name, &bytes);
    }
    save(&out, "hdr", "flat.hdr", &hdr(false));
    save(&out, "hdr", "rle.hdr", &hdr(true));
    for (name, bytes) in image_seeds() {
        let target = if name.ends_with(".png") {
            "png"
        } else {
            "jpeg"
        };
        save(&out, target, name, &bytes);
    }
    for (name, text) in OBJS {
        save(&out, "obj", name, text.as_bytes());
    }
    save(&out, "ply", "ascii.ply", PLY_ASCII.as_bytes());
    save(&out, "ply", "le.ply", &ply_binary(false));
    save(&out, "ply", "be.ply", &ply_binary(true));
    grid_seeds(&out);
    vdb_seeds(&out, &repo);
}

fn save(out: &Path, target: &str, name: &str, bytes: &[u8]) {
    let dir = out.join(target);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join(name), bytes).unwrap();
}

const SPHERE: &str = r#"{"type":"sphere","radius":0.8,"material":"m"}"#;
const TINY: &str = r#"{"format":1,"camera":{"look_at":{"origin":[0,1,4],"target":[0,0,0],"up":[0,1,0]},"fov":45},"film":{"width":8,"height":8},"materials":{"m":{"type":"diffuse","reflectance":[0.6,0.5,0.4]}},"shapes":[{"type":"sphere","radius":0.8,"material":"m"}],"lights":[{"type":"point","position":[1,3,2],"intensity":[8,8,8]}]}"#;
const QUAD_OBJ: &str = "v -2 -1 -2\nv 2 -1 -2\nv 2 -1 2\nv -2 -1 2\nf 4 3 2 1\n";
const OBJS: [(&str, &str); 3] = [
    ("quad.obj", QUAD_OBJ),
    (
        "normals.obj",
        "mtllib x.mtl\no a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvt 0 0\nusemtl m\nf 1/1/1 2/1/1 3/1/1\n",
    ),
    (
        "negative.obj",
        "g b\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf -5 -4 -3 -2 -1\nl 1 2\n",
    ),
];
const PLY_ASCII: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n";

/// The repository's scenes, compacted (same values, no indentation).
fn scene_seeds(repo: &Path) -> Vec<(String, String)> {
    let mut out = vec![("tiny.json".to_string(), TINY.to_string())];
    for dir in ["scenes", "scenes/smallvcm", "scenes/media"] {
        for entry in std::fs::read_dir(repo.join(dir)).unwrap().flatten() {
            let path = entry.path();
            if path.extension().is_some_and(|e| e == "json") {
                let text = std::fs::read_to_string(&path).unwrap();
                let value: serde_json::Value = serde_json::from_str(&text).unwrap();
                let name = path.file_name().unwrap().to_string_lossy().into_owned();
                out.push((name, value.to_string()));
            }
        }
    }
    out
}

fn tar(scene: &str, files: &[(&str, &[u8])]) -> Vec<u8> {
    let mut b = tar::Builder::new(Vec::new());
    let mut add = |name: &str, data: &[u8]| {
        let mut h = tar::Header::new_gnu();
        h.set_size(data.len() as u64);
        h.set_mode(0o644);
        b.append_data(&mut h, name, data).unwrap();
    };
    add("scene.json", scene.as_bytes());
    for (name, data) in files {
        add(name, data);
    }
    b.into_inner().unwrap()
}

fn zip(scene: &str, files: &[(&str, &[u8])]) -> Vec<u8> {
    let mut z = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let opts = zip::write::SimpleFileOptions::default();
    z.start_file("scene.json", opts).unwrap();
    z.write_all(scene.as_bytes()).unwrap();
    for (name, data) in files {
        z.start_file(*name, opts).unwrap();
        z.write_all(data).unwrap();
    }
    z.finish().unwrap().into_inner()
}

/// caustic's own output, and the crate's other compressions, sample types, tiles
/// and parts, all 4 x 3 pixels.
fn exr_seeds() -> Vec<(&'static str, Vec<u8>)> {
    let px = (0..12).map(|i| Vec3::new(i as f32, 0.5, 1.0 / (i as f32 + 1.0)));
    let ours = encode_exr(&Image::from_pixels(4, 3, px.collect())).unwrap();
    use x::Compression::*;
    let mut out = vec![("caustic.exr", ours)];
    let kinds: [(&str, x::Compression, bool, bool); 8] = [
        ("rle.exr", RLE, false, false),
        ("zip1.exr", ZIP1, false, false),
        ("piz.exr", PIZ, false, false),
        ("pxr24.exr", PXR24, false, false),
        ("b44_f16.exr", B44, true, false),
        ("b44a_f16.exr", B44A, true, false),
        ("none_tiles.exr", Uncompressed, false, true),
        ("zip16_f16_tiles.exr", ZIP16, true, true),
    ];
    for (name, c, half, tiles) in kinds {
        out.push((name, exr_file(c, half, tiles, 1)));
    }
    out.push(("two_parts.exr", exr_file(ZIP16, false, false, 2)));
    out
}

fn exr_file(compression: x::Compression, half: bool, tiles: bool, parts: usize) -> Vec<u8> {
    let (w, h) = (4, 3);
    let samples = |v: f32| {
        if half {
            FlatSamples::F16(vec![x::f16::from_f32(v); w * h])
        } else {
            FlatSamples::F32((0..w * h).map(|i| v + i as f32).collect())
        }
    };
    let blocks = if tiles {
        x::Blocks::Tiles(x::Vec2(2, 2))
    } else {
        x::Blocks::ScanLines
    };
    let encoding = x::Encoding {
        compression,
        blocks,
        line_order: x::LineOrder::Increasing,
    };
    let layers: Vec<_> = (0..parts)
        .map(|p| {
            let channels = [("B", 0.25), ("G", 0.5), ("R", 1.0)]
                .map(|(c, v)| AnyChannel::new(c, samples(v)))
                .to_vec();
            let attributes = LayerAttributes::named(format!("part{p}").as_str());
            Layer::new(
                (w, h),
                attributes,
                encoding,
                AnyChannels::sort(channels.into()),
            )
        })
        .collect();
    let bounds = x::IntegerBounds::from_dimensions((w, h));
    let image = x::Image::from_layers(x::ImageAttributes::new(bounds), layers);
    let mut out = std::io::Cursor::new(Vec::new());
    x::WritableImage::write(&image)
        .to_buffered(&mut out)
        .unwrap();
    out.into_inner()
}

/// Small PNGs (RGB, grey with alpha, 16-bit, palette-free) and JPEGs (colour, grey).
fn image_seeds() -> Vec<(&'static str, Vec<u8>)> {
    use image::{DynamicImage, ImageFormat};
    let rgb = image::RgbImage::from_fn(8, 4, |x, y| image::Rgb([x as u8 * 30, y as u8 * 60, 90]));
    let grey_alpha =
        image::GrayAlphaImage::from_fn(5, 3, |x, y| image::LumaA([x as u8 * 50, y as u8 * 80]));
    let deep = image::ImageBuffer::<image::Rgb<u16>, _>::from_fn(4, 4, |x, y| {
        image::Rgb([x as u16 * 9000, y as u16 * 9000, 4000])
    });
    let encode = |img: DynamicImage, format: ImageFormat| {
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, format).unwrap();
        out.into_inner()
    };
    vec![
        ("rgb.png", encode(rgb.clone().into(), ImageFormat::Png)),
        (
            "grey_alpha.png",
            encode(grey_alpha.into(), ImageFormat::Png),
        ),
        ("deep.png", encode(deep.into(), ImageFormat::Png)),
        ("rgb.jpg", encode(rgb.clone().into(), ImageFormat::Jpeg)),
        (
            "grey.jpg",
            encode(
                DynamicImage::from(rgb).into_luma8().into(),
                ImageFormat::Jpeg,
            ),
        ),
    ]
}

/// A Radiance file of 8 x 2 pixels, flat or run-length encoded (new style).
fn hdr(rle: bool) -> Vec<u8> {
    let mut out = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 8\n".to_vec();
    for row in 0..2u8 {
        if rle {
            out.extend([2, 2, 0, 8]);
            for channel in [128 + row, 64, 32, 129] {
                out.extend([128 + 8, channel]);
            }
        } else {
            for i in 0..8u8 {
                out.extend([100 + i, 50 + row, 25, 129]);
            }
        }
    }
    out
}

fn ply_binary(big: bool) -> Vec<u8> {
    let order = if big { "big" } else { "little" };
    let mut out = format!(
        "ply\nformat binary_{order}_endian 1.0\nelement vertex 4\nproperty float x\n\
         property float y\nproperty double z\nelement face 2\n\
         property list uchar uint vertex_indices\nend_header\n"
    )
    .into_bytes();
    let mut put = |mut b: Vec<u8>| {
        if big {
            b.reverse();
        }
        out.extend(b);
    };
    for p in [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
        put(p[0].to_le_bytes().to_vec());
        put(p[1].to_le_bytes().to_vec());
        put((p[2] as f64).to_le_bytes().to_vec());
    }
    for f in [[0u32, 1, 2], [0, 2, 3]] {
        put(vec![3]);
        for i in f {
            put(i.to_le_bytes().to_vec());
        }
    }
    out
}

/// The two smaller OpenVDB test files (zlib, and half floats without compression).
fn vdb_seeds(out: &Path, repo: &Path) {
    for name in ["density_zip.vdb", "temperature_active.vdb"] {
        let bytes = std::fs::read(repo.join("tests/data").join(name)).unwrap();
        save(out, "vdb", name, &bytes);
    }
}

/// A 3 x 4 x 5 grid as .vol and as a raw grid (header, NUL, data: raw_grid's input).
fn grid_seeds(out: &Path) {
    let grid = DenseGrid {
        dims: [3, 4, 5],
        data: (0..60).map(|i| i as f32 * 0.25).collect(),
        bounds: Some(([-1.0, 0.0, 2.0], [1.0, 2.0, 3.5])),
    };
    let tmp = tempfile::tempdir().unwrap();
    write_vol(&tmp.path().join("g.vol"), &grid).unwrap();
    save(
        out,
        "vol",
        "g.vol",
        &std::fs::read(tmp.path().join("g.vol")).unwrap(),
    );
    write_raw(&tmp.path().join("g.json"), &grid).unwrap();
    let mut raw = std::fs::read(tmp.path().join("g.json")).unwrap();
    raw.push(0);
    raw.extend(std::fs::read(tmp.path().join("g.raw")).unwrap());
    save(out, "raw_grid", "g.bin", &raw);
    let flat = br#"{"dims":[1,1,2],"data":"d.raw"}"#;
    save(
        out,
        "raw_grid",
        "flat.bin",
        &[&flat[..], &[0], &[0; 8]].concat(),
    );
}
