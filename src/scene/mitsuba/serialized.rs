//! Mitsuba's `serialized` meshes: a zlib stream per shape (flags, counts, positions,
//! optional normals, texture coordinates and colours, triangles), shapes indexed by a
//! table of offsets at the end of the file. Imported as an inline mesh.

use super::budget::{Budget, Work};
use super::node::Node;
use super::params::Params;
use super::Ctx;
use crate::scene::error::Result;
use crate::scene::format::GeometryDesc;
use std::io::Read;

const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const FACE_NORMALS: u32 = 0x0010;
const DOUBLE_PRECISION: u32 = 0x2000;

/// More vertices or triangles than this in one shape is taken for a damaged file.
const MAX_COUNT: u64 = 1 << 28;
/// Mesh data compresses two to four times; a stream that expands far more is a
/// decompression bomb, refused before it can exhaust the server's memory.
const MAX_EXPANSION: u64 = 64;

pub fn shape(n: &Node, p: &Params, ctx: &mut Ctx) -> Result<GeometryDesc> {
    let (fnode, name) = p
        .string("filename")?
        .ok_or_else(|| n.err("needs a filename"))?;
    let file = ctx.file_ref(fnode, name)?;
    let index = p.int("shape_index")?.unwrap_or(0);
    let face_normals = p.boolean("face_normals")?.unwrap_or(false);
    let bytes = match ctx.serialized.get(&file) {
        Some(b) => b.clone(),
        None => {
            let path = ctx.path_of(&file);
            let b = std::fs::read(path).map_err(|e| n.err(format!("\"{name}\": {e}")))?;
            let b = std::rc::Rc::new(b);
            ctx.serialized.insert(file.clone(), b.clone());
            b
        }
    };
    let mesh =
        read(&bytes, index, &mut ctx.budget).map_err(|e| n.err(format!("\"{name}\": {e}")))?;
    let normals = match (mesh.normals, face_normals) {
        (Some(normals), false) => Some(normals),
        (None, false) => {
            ctx.warn(
                n,
                "the mesh has no vertex normals: Mitsuba would compute smooth normals, caustic \
                 shades it flat (set face_normals=\"true\" to make Mitsuba agree)",
            );
            None
        }
        (_, true) => None,
    };
    Ok(GeometryDesc::Mesh {
        positions: mesh.positions,
        indices: mesh.indices,
        normals,
        uvs: None,
    })
}

struct Mesh {
    positions: Vec<[f32; 3]>,
    normals: Option<Vec<[f32; 3]>>,
    indices: Vec<[u32; 3]>,
}

fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(
        b.get(at..at.checked_add(4)?)?.try_into().ok()?,
    ))
}

fn u64_at(b: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(
        b.get(at..at.checked_add(8)?)?.try_into().ok()?,
    ))
}

/// Where shape `index` starts, from the table of offsets at the end of the file.
/// Every number here comes from the file, so every step is checked: an offset of
/// 2^64 - 2 must be an error, not a wrap to byte 2.
fn shape_offset(bytes: &[u8], index: i64, v4: bool) -> std::result::Result<usize, String> {
    let len = bytes.len() as u64;
    let count = u32_at(bytes, bytes.len().saturating_sub(4)).ok_or("truncated file")?;
    let index = u64::try_from(index)
        .ok()
        .filter(|&i| i < u64::from(count))
        .ok_or_else(|| format!("shape_index {index}: the file holds {count} shapes"))?;
    let width: u64 = if v4 { 8 } else { 4 };
    let table = (u64::from(count) * width)
        .checked_add(4)
        .and_then(|end| len.checked_sub(end))
        .ok_or_else(|| format!("a table of {count} shape offsets does not fit in the file"))?;
    // Below `len`, so it fits a usize.
    let at = (table + width * index) as usize;
    let off = if v4 {
        u64_at(bytes, at)
    } else {
        u32_at(bytes, at).map(u64::from)
    }
    .ok_or("truncated offset table")?;
    match usize::try_from(off) {
        Ok(start) if off < len => Ok(start),
        _ => Err(format!(
            "shape {index} is said to start at byte {off}, past the end of the file \
             ({len} bytes)"
        )),
    }
}

/// Shape `index` of a serialized file, its decompressed bytes spent from `spent`.
fn read(bytes: &[u8], index: i64, spent: &mut Budget) -> std::result::Result<Mesh, String> {
    let version = bytes.get(2..4).map(|v| u16::from_le_bytes([v[0], v[1]]));
    if bytes.get(0..2) != Some(&[0x1C, 0x04][..]) || !matches!(version, Some(3 | 4)) {
        return Err("not a Mitsuba serialized file (version 3 or 4)".into());
    }
    let v4 = version == Some(4);
    let start = match index {
        0 => 0,
        _ => shape_offset(bytes, index, v4)?,
    };
    let body = start
        .checked_add(4)
        .and_then(|at| bytes.get(at..))
        .ok_or("truncated file")?;
    let mut z = flate2::read::ZlibDecoder::new(body);
    let mut budget = MAX_EXPANSION * body.len() as u64 + 4096;
    let mut take = |n: u64| -> std::result::Result<Vec<u8>, String> {
        budget = budget.checked_sub(n).ok_or_else(|| {
            format!("expands to more than {MAX_EXPANSION} times its compressed size; refused")
        })?;
        spent.spend(Work::MeshBytes, n)?;
        let mut buf = Vec::new();
        (&mut z)
            .take(n)
            .read_to_end(&mut buf)
            .map_err(|e| format!("zlib: {e}"))?;
        if buf.len() as u64 != n {
            return Err("the compressed data ends early".into());
        }
        Ok(buf)
    };
    let flags = u32::from_le_bytes(take(4)?.try_into().expect("4 bytes"));
    if v4 {
        // The shape's name, NUL-terminated.
        while take(1)?[0] != 0 {}
    }
    let nv = u64::from_le_bytes(take(8)?.try_into().expect("8 bytes"));
    let nt = u64::from_le_bytes(take(8)?.try_into().expect("8 bytes"));
    if nv > MAX_COUNT || nt > MAX_COUNT {
        return Err(format!("{nv} vertices and {nt} triangles: too many"));
    }
    let real = if flags & DOUBLE_PRECISION != 0 { 8 } else { 4 };
    let mut reals = |count: u64| -> std::result::Result<Vec<f32>, String> {
        let b = take(count * real)?;
        Ok(if real == 8 {
            b.chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().expect("8")) as f32)
                .collect()
        } else {
            b.chunks_exact(4)
                .map(|c| f32::from_le_bytes(c.try_into().expect("4")))
                .collect()
        })
    };
    let triples = |v: Vec<f32>| v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let positions: Vec<[f32; 3]> = triples(reals(3 * nv)?);
    let normals: Option<Vec<[f32; 3]>> = if flags & HAS_NORMALS != 0 {
        Some(triples(reals(3 * nv)?))
    } else {
        None
    };
    if flags & HAS_TEXCOORDS != 0 {
        reals(2 * nv)?;
    }
    if flags & HAS_COLORS != 0 {
        reals(3 * nv)?;
    }
    // (Indices are 64-bit only past 2^32 vertices, beyond MAX_COUNT.)
    let b = take(3 * nt * 4)?;
    let idx: Vec<u32> = b
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes(c.try_into().expect("4")))
        .collect();
    let indices: Vec<[u32; 3]> = idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    if let Some(bad) = indices.iter().flatten().find(|&&i| i as u64 >= nv) {
        return Err(format!("face index {bad} out of range ({nv} vertices)"));
    }
    let normals = normals.filter(|_| flags & FACE_NORMALS == 0);
    Ok(Mesh {
        positions,
        normals,
        indices,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A serialized file of one shape (version 4), for tests.
    fn write_one(positions: &[[f32; 3]], indices: &[[u32; 3]]) -> Vec<u8> {
        use std::io::Write;
        let mut raw = Vec::new();
        raw.extend(0x1000u32.to_le_bytes());
        raw.extend(b"mesh\0");
        raw.extend((positions.len() as u64).to_le_bytes());
        raw.extend((indices.len() as u64).to_le_bytes());
        positions
            .iter()
            .flatten()
            .for_each(|x| raw.extend(x.to_le_bytes()));
        indices
            .iter()
            .flatten()
            .for_each(|i| raw.extend(i.to_le_bytes()));
        let mut out = vec![0x1C, 0x04, 4, 0];
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&raw).expect("in memory");
        out.extend(z.finish().expect("in memory"));
        out.extend(0u64.to_le_bytes());
        out.extend(1u32.to_le_bytes());
        out
    }

    #[test]
    fn a_written_mesh_reads_back() {
        let pos = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.5]];
        let mesh = read(&write_one(&pos, &[[0, 1, 2]]), 0, &mut Budget::default()).unwrap();
        assert_eq!(mesh.positions, pos);
        assert_eq!(mesh.indices, [[0, 1, 2]]);
        assert!(mesh.normals.is_none());
        assert!(
            read(&write_one(&pos, &[[0, 1, 3]]), 0, &mut Budget::default())
                .err()
                .unwrap()
                .contains("out of range")
        );
        assert!(read(b"junk", 0, &mut Budget::default()).is_err());
    }

    /// `file` (one shape) with its offset table replaced by `offsets` and `count`.
    fn with_table(file: &[u8], offsets: &[u64], count: u32) -> Vec<u8> {
        let mut out = file[..file.len() - 12].to_vec();
        offsets.iter().for_each(|o| out.extend(o.to_le_bytes()));
        out.extend(count.to_le_bytes());
        out
    }

    #[test]
    fn offsets_and_counts_from_the_file_are_checked() {
        let one = write_one(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], &[[0, 1, 2]]);
        let read1 = |bytes: &[u8]| read(bytes, 1, &mut Budget::default()).map(|m| m.indices);
        // Shape 1 at the start of the file (where shape 0 is) reads as shape 0.
        assert_eq!(read1(&with_table(&one, &[0, 0], 2)), Ok(vec![[0, 1, 2]]));
        // 2^64 - 2 used to wrap around to byte 2.
        let e = read1(&with_table(&one, &[0, u64::MAX - 1], 2)).unwrap_err();
        assert!(
            e.contains("start at byte 18446744073709551614, past the end"),
            "{e}"
        );
        let len = one.len() as u64 + 8; // with two offsets
        let e = read1(&with_table(&one, &[0, len], 2)).unwrap_err();
        assert!(e.contains("past the end"), "{e}");
        // A count whose table would be larger than the file (it used to underflow).
        let e = read1(&with_table(&one, &[0], u32::MAX)).unwrap_err();
        assert!(e.contains("does not fit in the file"), "{e}");
        let e = read(&with_table(&one, &[0], 1), -1, &mut Budget::default()).err();
        assert_eq!(
            e.as_deref(),
            Some("shape_index -1: the file holds 1 shapes")
        );
    }

    #[test]
    fn the_import_budget_bounds_what_all_shapes_decompress() {
        // Distinct vertices, which compress little: the expansion bound allows them.
        let pos: Vec<[f32; 3]> = (0..1000).map(|i| [i as f32, 0.5, -(i as f32)]).collect();
        let file = write_one(&pos, &[[0, 1, 2]]);
        assert!(read(&file, 0, &mut Budget::default()).is_ok());
        let mut budget = Budget::default();
        let left = Work::MeshBytes.limit() - 10_000;
        budget.spend(Work::MeshBytes, left).unwrap();
        let e = read(&file, 0, &mut budget).err().unwrap();
        assert!(e.contains("MiB of serialized mesh data"), "{e}");
    }

    #[test]
    fn a_decompression_bomb_is_refused() {
        // A million identical vertices compress about a thousand times.
        let pos = vec![[0.0; 3]; 1 << 20];
        let file = write_one(&pos, &[[0, 1, 2]]);
        assert!(file.len() < (12 << 20) / 64, "{} bytes", file.len());
        let e = read(&file, 0, &mut Budget::default()).err().unwrap();
        assert!(e.contains("times its compressed size"), "{e}");
    }
}
