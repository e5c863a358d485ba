//! Triangle meshes: Wavefront OBJ through `tobj` (triangles only, positions checked,
//! texture coordinates as Mitsuba 3 stores them), PLY through [`super::ply`], and the
//! vertex normals Mitsuba 3 computes for a mesh whose file has none.

use glam::{Vec2, Vec3};
use std::path::Path;

/// An indexed triangle mesh in object space.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Vertex normals from the file, one per position, or empty when it has none.
    pub normals: Vec<Vec3>,
    /// Vertex texture coordinates, one per position, or empty when the file has none;
    /// equal to Mitsuba's `vertex_texcoords` (an OBJ's `vt` v is flipped to 1 − v, a
    /// PLY's is not, as Mitsuba's loaders do by default).
    pub uvs: Vec<Vec2>,
    /// Triangles as indices into `positions` (and `normals`, `uvs`), counter-clockwise front.
    pub triangles: Vec<[u32; 3]>,
}

impl MeshData {
    /// The triangles' corner positions.
    pub fn corners(&self) -> Vec<[Vec3; 3]> {
        self.triangles.iter().map(|t| t.map(|i| self.positions[i as usize])).collect()
    }
}

/// Vertex normals computed from the faces as Mitsuba 3's `Mesh::recompute_vertex_normals`
/// does (Thürmer and Wüthrich, "Computing vertex normals from polygonal facets", JGT
/// 1998): each face's unit normal weighted by the face's angle at the vertex, summed over
/// the faces that share the vertex (by index), normalised; a vertex whose sum is zero
/// gets (1, 0, 0) as in Mitsuba. Zero-area faces are skipped.
pub fn vertex_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut sum = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        let v = t.map(|i| positions[i as usize]);
        let n = (v[1] - v[0]).cross(v[2] - v[0]);
        let len = cross_length(n);
        // Zero-area (or NaN) faces have no normal.
        if len.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            continue;
        }
        let n = n / len;
        for j in 0..3 {
            let a = (v[(j + 1) % 3] - v[j]).normalize_or_zero();
            let b = (v[(j + 2) % 3] - v[j]).normalize_or_zero();
            sum[t[j] as usize] += n * unit_angle(a, b);
        }
    }
    sum.into_iter().map(|n| if n.length() != 0.0 { n / n.length() } else { Vec3::X }).collect()
}

/// The length of a triangle's edge cross product `n`. Within the scene's coordinate bound
/// a cross product is finite but its square can overflow f32 (edges near 10^10 give
/// components near 10^20); then the length is taken in f64 (found by fuzzing). Below
/// that it is glam's `length`, bit for bit.
pub(super) fn cross_length(n: Vec3) -> f32 {
    let len = n.length();
    if len.is_finite() {
        len
    } else {
        n.as_dvec3().length() as f32
    }
}

/// The angle between unit vectors, accurate near 0 and π (Mitsuba's `unit_angle`).
fn unit_angle(a: Vec3, b: Vec3) -> f32 {
    let dot = a.dot(b);
    let t = 2.0 * (0.5 * (b - a * 1f32.copysign(dot)).length()).min(1.0).asin();
    if dot >= 0.0 {
        t
    } else {
        std::f32::consts::PI - t
    }
}

/// Reads the triangles of an OBJ file (faces fan-triangulated by tobj), in object space.
/// Errors are messages to be placed after the field that named the file.
pub fn load_obj(path: &Path) -> Result<Vec<[Vec3; 3]>, String> {
    load_obj_mesh(path).map(|m| m.corners())
}

/// Reads an OBJ file as an indexed mesh. A vertex is a distinct (position, texture
/// coordinate, normal) index triple, as in Mitsuba's OBJ loader, so computed normals are
/// shared exactly where Mitsuba shares them; the file's normals (`vn`) are kept when every
/// face corner has one. Texture coordinates (`vt`) are kept when the file has any, with v
/// flipped to 1 − v as Mitsuba's `flip_tex_coords` (default true) does; a corner without
/// one gets tobj's stand-in (the previous corner's), a vertex of an object read before any
/// `vt` (0, 0).
pub fn load_obj_mesh(path: &Path) -> Result<MeshData, String> {
    // A device or a pipe would be read without end or block for ever.
    match std::fs::metadata(path) {
        Ok(m) if !m.is_file() => return Err(format!("mesh `{}` is not a regular file", path.display())),
        _ => {}
    }
    let bytes = std::fs::read(path).map_err(|e| format!("cannot open mesh `{}`: {e}", path.display()))?;
    check_face_indices(&bytes)
        .map_err(|(line, msg)| format!("malformed OBJ `{}`: line {line}: {msg}", path.display()))?;
    let opts = tobj::LoadOptions { triangulate: true, single_index: false, ignore_points: true, ignore_lines: true };
    // Materials are not used: never let tobj open .mtl files next to the mesh.
    let load = |bytes: &[u8]| tobj::load_obj_buf(&mut &bytes[..], &opts, |_| Err(tobj::LoadError::OpenFileFailed));
    let (models, _) = load(&bytes).map_err(|e| {
        let (line, what) = match std::str::from_utf8(&bytes) {
            Err(u) => (line_of(&bytes, u.valid_up_to()), format!("not UTF-8 text (byte {})", u.valid_up_to() + 1)),
            Ok(_) => (failing_line(&bytes, e, |b| load(b).err()), describe(&e).to_owned()),
        };
        format!("malformed OBJ `{}`: line {line}: {what}", path.display())
    })?;
    let mut out = MeshData::default();
    let mut with_normals = true;
    for model in &models {
        let m = &model.mesh;
        let p = &m.positions;
        if let Some(bad) = p.iter().chain(&m.normals).position(|x| !x.is_finite()) {
            let (what, keyword) = if bad < p.len() { ("vertex", "v") } else { ("normal", "vn") };
            let k = if bad < p.len() { bad } else { bad - p.len() };
            return Err(format!(
                "malformed OBJ `{}`: {}{what} {} of object `{}` has a non-finite coordinate",
                path.display(),
                nonfinite_line(&bytes, keyword).map_or_else(String::new, |l| format!("line {l}: ")),
                k / 3 + 1,
                model.name
            ));
        }
        with_normals &= !m.normal_indices.is_empty() && m.normal_indices.len() == m.indices.len();
        if let Some(bad) = m.texcoords.iter().position(|x| !x.is_finite()) {
            return Err(format!(
                "malformed OBJ `{}`: {}texture coordinate {} of object `{}` is not finite",
                path.display(),
                nonfinite_line(&bytes, "vt").map_or_else(String::new, |l| format!("line {l}: ")),
                bad / 2 + 1,
                model.name
            ));
        }
    }
    // tobj gives every object read after the first `vt` line a coordinate per corner.
    let with_uvs = models.iter().any(|m| !m.mesh.texcoords.is_empty());
    let mut ids: rustc_hash::FxHashMap<(usize, u32, u32, u32), u32> = Default::default();
    for (mi, model) in models.iter().enumerate() {
        let m = &model.mesh;
        let (p, nrm, tc) = (&m.positions, &m.normals, &m.texcoords);
        for (f, face) in m.indices.chunks_exact(3).enumerate() {
            let mut tri = [0u32; 3];
            for k in 0..3 {
                let c = 3 * f + k;
                let i = face[k] as usize;
                if 3 * i + 2 >= p.len() {
                    return Err(format!("malformed OBJ `{}`: face refers to missing vertex {}", path.display(), i + 1));
                }
                let t = m.texcoord_indices.get(c).copied().unwrap_or(u32::MAX);
                let n = if with_normals { m.normal_indices[c] } else { u32::MAX };
                let next = out.positions.len() as u32;
                tri[k] = *ids.entry((mi, face[k], t, n)).or_insert_with(|| {
                    out.positions.push(Vec3::new(p[3 * i], p[3 * i + 1], p[3 * i + 2]));
                    next
                });
                if tri[k] == next && with_normals {
                    let n = n as usize;
                    if 3 * n + 2 >= nrm.len() {
                        return Err(format!(
                            "malformed OBJ `{}`: face refers to missing normal {}",
                            path.display(),
                            n + 1
                        ));
                    }
                    out.normals.push(Vec3::new(nrm[3 * n], nrm[3 * n + 1], nrm[3 * n + 2]));
                }
                if tri[k] == next && with_uvs {
                    // tobj has checked the index against its coordinates.
                    let uv = m.texcoord_indices.get(c).and_then(|&t| {
                        let t = 2 * t as usize;
                        Some(Vec2::new(*tc.get(t)?, 1.0 - *tc.get(t + 1)?))
                    });
                    out.uvs.push(uv.unwrap_or(Vec2::ZERO));
                }
            }
            out.triangles.push(tri);
        }
    }
    if out.triangles.is_empty() {
        return Err(format!("OBJ `{}` contains no triangles", path.display()));
    }
    Ok(out)
}

/// Refuses, with its line, a face index that tobj 4.0.5 would overflow on: it multiplies
/// an index before its own bounds check (`vt * 2 + 1`), and a relative index reaching
/// before the first element of its kind (positions, texture coordinates, normals) or a
/// huge one becomes close to `usize::MAX`: a panic with overflow checks on, a wrapped,
/// wrong bounds check without. A relative index must stay within the elements declared
/// above its face, an absolute one within the file's count; every index of a valid file
/// does, so no valid file is refused here.
fn check_face_indices(bytes: &[u8]) -> Result<(), (usize, String)> {
    // The lines and words tobj reads; bytes at a time where the text is ASCII (the usual
    // mesh), since a word split by chars costs most of this check's time.
    if bytes.is_ascii() {
        // `char::is_whitespace` on ASCII, vertical tab included.
        fn words(l: &[u8]) -> impl Iterator<Item = &[u8]> {
            l.split(|b| matches!(b, b' ' | b'\t' | b'\n' | 0x0b | 0x0c | b'\r')).filter(|w| !w.is_empty())
        }
        return check_indices(|| bytes.split(|&b| b == b'\n'), words);
    }
    let text = String::from_utf8_lossy(bytes);
    check_indices(
        || text.lines().map(str::as_bytes),
        |l| std::str::from_utf8(l).unwrap_or("").split_whitespace().map(str::as_bytes),
    )
}

/// [`check_face_indices`] over the `lines` of a file, each split into `words`.
fn check_indices<'a, L, W, I>(lines: impl Fn() -> L, words: W) -> Result<(), (usize, String)>
where
    L: Iterator<Item = &'a [u8]>,
    W: Fn(&'a [u8]) -> I,
    I: Iterator<Item = &'a [u8]>,
{
    let kind = |first: Option<&[u8]>| match first {
        Some([b'v']) => Some(0),
        Some([b'v', b't']) => Some(1),
        Some([b'v', b'n']) => Some(2),
        _ => None,
    };
    let mut total = [0u64; 3];
    for line in lines() {
        if let Some(k) = kind(words(line).next()) {
            total[k] += 1;
        }
    }
    const KINDS: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    let mut above = [0u64; 3];
    for (n, line) in lines().enumerate() {
        let mut w = words(line);
        let first = w.next();
        if let Some(k) = kind(first) {
            above[k] += 1;
            continue;
        }
        // tobj reads `l` (polyline) corners as it reads faces: a polyline of three or more
        // corners becomes triangles, so its indices need the same check.
        let what = match first {
            Some([b'f']) => "face",
            Some([b'l']) => "line element",
            _ => continue,
        };
        for corner in w {
            for (k, index) in corner.split(|&b| b == b'/').take(3).enumerate() {
                // Not a number: tobj's own error.
                let Some(i) = parse_index(index) else { continue };
                if i == 0 {
                    // tobj refuses a vertex 0 without a line and ignores texture
                    // coordinate or normal 0; OBJ indices start at 1.
                    return Err((n + 1, format!("{what} refers to {} 0; OBJ indices start at 1", KINDS[k])));
                }
                let (limit, whose) = if i < 0 { (above[k], "above it") } else { (total[k], "in the file") };
                if i.unsigned_abs() > limit {
                    return Err((n + 1, format!("{what} refers to {} {i}, but there are {limit} {whose}", KINDS[k])));
                }
            }
        }
    }
    Ok(())
}

/// `index` as `str::parse::<i64>` reads it (an optional sign, then only digits, within
/// range), without its UTF-8 check.
fn parse_index(index: &[u8]) -> Option<i64> {
    let (negative, digits) = match index {
        [b'-', rest @ ..] => (true, rest),
        [b'+', rest @ ..] => (false, rest),
        _ => (false, index),
    };
    if digits.is_empty() {
        return None;
    }
    digits.iter().try_fold(0i64, |n, &b| {
        let d = i64::from(b.wrapping_sub(b'0'));
        if d > 9 {
            return None;
        }
        let n = n.checked_mul(10)?;
        if negative {
            n.checked_sub(d)
        } else {
            n.checked_add(d)
        }
    })
}

/// The first line of a `keyword` (`v`, `vn`, `vt`) record with a number that is not
/// finite in f32 (`nan`, `inf`, `1e39`): tobj reads them without a word, and its
/// positions carry no line.
fn nonfinite_line(bytes: &[u8], keyword: &str) -> Option<usize> {
    bytes
        .split(|&b| b == b'\n')
        .position(|line| {
            let text = String::from_utf8_lossy(line);
            let mut words = text.split_whitespace();
            words.next() == Some(keyword) && words.any(|w| w.parse::<f32>().is_ok_and(|x| !x.is_finite()))
        })
        .map(|i| i + 1)
}

/// The line holding byte `at` (1-based).
fn line_of(bytes: &[u8], at: usize) -> usize {
    bytes[..at].iter().filter(|&&b| b == b'\n').count() + 1
}

/// Where tobj's `error` (which carries no line) arises: the first line whose prefix of the
/// file fails with the same error, found by bisection over line ends, so an error costs a
/// few more loads of the file and a valid file none.
fn failing_line(bytes: &[u8], error: tobj::LoadError, load: impl Fn(&[u8]) -> Option<tobj::LoadError>) -> usize {
    let ends: Vec<usize> =
        bytes.iter().enumerate().filter(|(_, &b)| b == b'\n').map(|(i, _)| i + 1).chain([bytes.len()]).collect();
    // Invariant: the first `lo` lines load (or fail otherwise); the first `hi` fail with `error`.
    let (mut lo, mut hi) = (0, ends.len());
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if load(&bytes[..ends[mid - 1]]) == Some(error) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

fn describe(e: &tobj::LoadError) -> &'static str {
    use tobj::LoadError::*;
    match e {
        OpenFileFailed => "cannot open file",
        ReadError => "read error (not text?)",
        UnrecognizedCharacter => "unrecognized character",
        PositionParseError => "bad vertex position (`v` line)",
        NormalParseError => "bad normal (`vn` line)",
        TexcoordParseError => "bad texture coordinate (`vt` line)",
        FaceParseError => "bad face (`f` line)",
        MaterialParseError => "bad material statement",
        InvalidObjectName => "bad object name",
        FaceVertexOutOfBounds => "a face refers to a vertex that does not exist",
        FaceTexCoordOutOfBounds => "a face refers to a texture coordinate that does not exist",
        FaceNormalOutOfBounds => "a face refers to a normal that does not exist",
        GenericFailure => "parse failure",
        InvalidPolygon => "invalid polygon",
        InvalidLoadOptionConfig => "invalid load options",
        _ => "parse failure",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn face_index_words_read_as_str_parse_reads_them() {
        for w in [
            "",
            "+",
            "-",
            "0",
            "-0",
            "+5",
            "-5",
            "12a",
            "1 2",
            "١",
            "9223372036854775807",
            "9223372036854775808",
            "-9223372036854775808",
            "-9223372036854775809",
            "+-1",
            "00017",
        ] {
            assert_eq!(parse_index(w.as_bytes()), w.parse::<i64>().ok(), "{w:?}");
        }
    }

    #[test]
    fn face_index_check_is_the_same_on_ascii_and_other_text() {
        let cases = [
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", Ok(())),
            ("v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 -4\r\n", Err(4)),
            ("v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n", Ok(())),
            ("v 0 0 0\nv 1 0 0\nf 1 2 -3\nv 0 1 0\n", Err(3)),
            ("v 0 0 0\n\tv 1 0 0\x0b\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n", Err(5)),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 0\n", Err(4)),
        ];
        for (text, want) in cases {
            // A comment with a non-ASCII word takes the other path.
            let other = format!("# é\n{text}");
            let line = |r: Result<(), (usize, String)>| r.map_err(|(l, _)| l);
            assert_eq!(line(check_face_indices(text.as_bytes())), want, "{text:?}");
            assert_eq!(line(check_face_indices(other.as_bytes())), want.map_err(|l| l + 1), "{other:?}");
        }
    }

    fn obj(text: &str) -> Result<MeshData, String> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.obj");
        std::fs::write(&path, text).unwrap();
        load_obj_mesh(&path)
    }

    #[test]
    fn obj_texture_coordinates_as_mitsuba_stores_them() {
        let m = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0.1 0.2\nvt 0.9 0.3\nvt 0.25 0.8\nvt 0.7 0.6\nf 1/1 2/2 3/3\nf 2/4 4/2 3/3\n")
            .unwrap();
        // Mitsuba 3.9.1 on the same file, `mi.traverse(mesh)`: faces [0, 1, 2, 3, 4, 2],
        // vertex_texcoords (0.1, 0.8), (0.9, 0.7), (0.25, 0.2), (0.7, 0.4), (0.9, 0.7) —
        // v flipped to 1 − v, position 2 split by its two texture coordinates.
        assert_eq!(m.triangles, vec![[0, 1, 2], [3, 4, 2]]);
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.positions[3], Vec3::X);
        let want = [(0.1, 0.8), (0.9, 0.7), (0.25, 0.2), (0.7, 0.4), (0.9, 0.7)];
        assert_eq!(m.uvs.len(), want.len());
        for (got, (u, v)) in m.uvs.iter().zip(want) {
            assert!((*got - Vec2::new(u, v)).abs().max_element() < 1e-6, "{got} vs ({u}, {v})");
        }
    }

    #[test]
    fn obj_without_texture_coordinates_has_none() {
        let m = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n").unwrap();
        assert!(m.uvs.is_empty());
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [1, 3, 2]]);
    }

    #[test]
    fn obj_non_finite_texture_coordinate_is_refused() {
        let e = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt nan 1\nf 1/1 2/2 3/1\n").unwrap_err();
        assert!(e.contains("texture coordinate 2"), "{e}");
    }
}
