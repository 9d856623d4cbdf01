//! Bad inputs that take more than a literal to build: tar and zip bundles with
//! unsafe, lying or corrupt entries, and EXR files whose header claims a huge image.

use serde_json::{json, Value};
use std::io::Write;

/// An OBJ quad for bundles.
pub const QUAD_OBJ: &[u8] = b"v -2 -1 -2\nv 2 -1 -2\nv 2 -1 2\nv -2 -1 2\nf 4 3 2 1\n";

/// `scene` with its second shape replaced by a mesh file of the bundle.
pub fn scene_with_mesh(mut scene: Value, kind: &str, file: &str) -> String {
    scene["shapes"][1] = json!({"type": kind, "filename": file, "material": "m"});
    scene.to_string()
}

/// `scene` lit by an environment map from the bundle.
pub fn scene_with_envmap(mut scene: Value, file: &str) -> String {
    scene["lights"] = json!([{"type": "envmap", "filename": file}]);
    scene.to_string()
}

// ---- tar ----------------------------------------------------------------------

/// One tar entry, written with its raw name (so unsafe paths reach the server as
/// given) and a size field that may lie about the data that follows.
pub struct TarEntry<'a> {
    pub name: &'a [u8],
    pub kind: tar::EntryType,
    pub data: &'a [u8],
    pub claimed_size: Option<u64>,
    pub link: &'a [u8],
}

pub fn file<'a>(name: &'a str, data: &'a [u8]) -> TarEntry<'a> {
    TarEntry {
        name: name.as_bytes(),
        kind: tar::EntryType::Regular,
        data,
        claimed_size: None,
        link: b"",
    }
}

pub fn tar(entries: &[TarEntry]) -> Vec<u8> {
    let mut b = tar::Builder::new(Vec::new());
    for e in entries {
        let mut h = tar::Header::new_gnu();
        h.set_size(e.claimed_size.unwrap_or(e.data.len() as u64));
        h.set_mode(0o644);
        h.set_entry_type(e.kind);
        let old = h.as_old_mut();
        old.name[..e.name.len()].copy_from_slice(e.name);
        old.linkname[..e.link.len()].copy_from_slice(e.link);
        h.set_cksum();
        b.append(&h, e.data).unwrap();
    }
    b.into_inner().unwrap()
}

/// A GNU long-name entry (type `L`) giving the next entry the path `long`.
pub fn tar_long_name(long: &str, data: &[u8]) -> Vec<u8> {
    let mut b = tar::Builder::new(Vec::new());
    let mut name = long.as_bytes().to_vec();
    name.push(0);
    let mut h = tar::Header::new_gnu();
    h.set_size(name.len() as u64);
    h.set_entry_type(tar::EntryType::GNULongName);
    h.as_old_mut().name[..13].copy_from_slice(b"././@LongLink");
    h.set_cksum();
    b.append(&h, name.as_slice()).unwrap();
    let mut h = tar::Header::new_gnu();
    h.set_size(data.len() as u64);
    h.set_mode(0o644);
    h.set_entry_type(tar::EntryType::Regular);
    h.as_old_mut().name[..11].copy_from_slice(b"placeholder");
    h.set_cksum();
    b.append(&h, data).unwrap();
    b.into_inner().unwrap()
}

/// Concatenates tar archives (drops the end-of-archive blocks of all but the last).
pub fn tar_concat(parts: &[Vec<u8>]) -> Vec<u8> {
    let mut out = Vec::new();
    for (i, p) in parts.iter().enumerate() {
        let mut p = p.as_slice();
        if i + 1 < parts.len() {
            while p.len() >= 512 && p[p.len() - 512..].iter().all(|&b| b == 0) {
                p = &p[..p.len() - 512];
            }
        }
        out.extend_from_slice(p);
    }
    out
}

// ---- zip ----------------------------------------------------------------------

pub fn zip(entries: &[(&str, &[u8])]) -> Vec<u8> {
    zip_with(entries, zip::CompressionMethod::Deflated)
}

pub fn zip_with(entries: &[(&str, &[u8])], method: zip::CompressionMethod) -> Vec<u8> {
    let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    for (name, data) in entries {
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(method)
            .large_file(data.len() > u32::MAX as usize);
        w.start_file(*name, opts).unwrap();
        w.write_all(data).unwrap();
    }
    w.finish().unwrap().into_inner()
}

/// A bundle with a symbolic link entry `name` -> `target`.
pub fn zip_symlink(scene: &str, name: &str, target: &str) -> Vec<u8> {
    let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let opts = zip::write::SimpleFileOptions::default();
    w.start_file("scene.json", opts).unwrap();
    w.write_all(scene.as_bytes()).unwrap();
    w.add_symlink(name, target, opts).unwrap();
    w.finish().unwrap().into_inner()
}

/// Where the data of the local entry `name` starts, and its compressed length.
pub fn zip_entry_data(z: &[u8], name: &str) -> (usize, usize) {
    let mut i = 0;
    while i + 30 <= z.len() {
        if &z[i..i + 4] == b"PK\x03\x04" {
            let u16_at = |o: usize| u16::from_le_bytes([z[i + o], z[i + o + 1]]) as usize;
            let u32_at = |o: usize| {
                u32::from_le_bytes([z[i + o], z[i + o + 1], z[i + o + 2], z[i + o + 3]]) as usize
            };
            let (csize, nlen, xlen) = (u32_at(18), u16_at(26), u16_at(28));
            if &z[i + 30..i + 30 + nlen] == name.as_bytes() {
                return (i + 30 + nlen + xlen, csize);
            }
            i += 30 + nlen + xlen + csize;
        } else {
            i += 1;
        }
    }
    panic!("no local entry {name}");
}

/// Sets bits of the general-purpose flag (offset 6 in local headers, 8 in central
/// ones) of every entry, e.g. 1 = encrypted.
pub fn zip_set_flags(mut z: Vec<u8>, bits: u16) -> Vec<u8> {
    for i in 0..z.len().saturating_sub(4) {
        let at = match &z[i..i + 4] {
            b"PK\x03\x04" => i + 6,
            b"PK\x01\x02" => i + 8,
            _ => continue,
        };
        let f = u16::from_le_bytes([z[at], z[at + 1]]) | bits;
        z[at..at + 2].copy_from_slice(&f.to_le_bytes());
    }
    z
}

/// Sets the compression method (offset 8 local, 10 central) of every entry.
pub fn zip_set_method(mut z: Vec<u8>, method: u16) -> Vec<u8> {
    for i in 0..z.len().saturating_sub(4) {
        let at = match &z[i..i + 4] {
            b"PK\x03\x04" => i + 8,
            b"PK\x01\x02" => i + 10,
            _ => continue,
        };
        z[at..at + 2].copy_from_slice(&method.to_le_bytes());
    }
    z
}

/// Makes the end-of-central-directory record claim `n` entries.
pub fn zip_claim_entries(mut z: Vec<u8>, n: u16) -> Vec<u8> {
    let at = (0..=z.len() - 22)
        .rev()
        .find(|&i| &z[i..i + 4] == b"PK\x05\x06")
        .expect("EOCD");
    z[at + 8..at + 10].copy_from_slice(&n.to_le_bytes());
    z[at + 10..at + 12].copy_from_slice(&n.to_le_bytes());
    z
}

// ---- EXR ----------------------------------------------------------------------

/// A small valid EXR.
pub fn exr(w: u32, h: u32) -> Vec<u8> {
    let px = (0..w * h)
        .map(|i| caustic::math::Vec3::new(0.5, 0.25 + i as f32 * 1e-3, 0.125))
        .collect();
    caustic::film::encode_exr(&caustic::film::Image::from_pixels(w, h, px)).unwrap()
}

/// A small valid EXR whose header (dataWindow and displayWindow) is patched to claim
/// `w` x `h` pixels; the file still holds the pixels of a 2x1 image. A reader that
/// trusts the header allocates w*h samples per channel before it reads a block.
pub fn exr_claiming(w: i32, h: i32) -> Vec<u8> {
    let mut b = exr(2, 1);
    let mut patched = 0;
    for attr in [&b"dataWindow\0box2i\0"[..], &b"displayWindow\0box2i\0"[..]] {
        let at = b
            .windows(attr.len())
            .position(|x| x == attr)
            .unwrap_or_else(|| panic!("no {:?} attribute", String::from_utf8_lossy(attr)));
        let v = at + attr.len() + 4; // after the i32 attribute size (16)
        for (k, val) in [0i32, 0, w - 1, h - 1].iter().enumerate() {
            b[v + 4 * k..v + 4 * k + 4].copy_from_slice(&val.to_le_bytes());
        }
        patched += 1;
    }
    assert_eq!(patched, 2);
    // The chunkCount attribute (written by the exr crate) must agree with the claimed
    // size, or a pedantic header check refuses the file before any allocation.
    let lines_per_block = {
        let attr = b"compression\0compression\0";
        let at = b
            .windows(attr.len())
            .position(|x| x == attr)
            .expect("compression");
        match b[at + attr.len() + 4] {
            0..=2 => 1,
            3 | 5 => 16,
            _ => 32,
        }
    };
    let attr = b"chunkCount\0int\0";
    if let Some(at) = b.windows(attr.len()).position(|x| x == attr) {
        let v = at + attr.len() + 4;
        let chunks = (h + lines_per_block - 1) / lines_per_block;
        b[v..v + 4].copy_from_slice(&chunks.to_le_bytes());
    }
    b
}

/// Deflate-friendly but not trivial data (for a bit-flip to land in real codes).
pub fn text_blob(n: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(n);
    let mut i = 0u64;
    while out.len() < n {
        out.extend_from_slice(format!("v {} {} {}\n", i % 97, (i * 7) % 13, i % 5).as_bytes());
        i += 1;
    }
    out.truncate(n);
    out
}
