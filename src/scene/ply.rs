//! PLY meshes (ascii, binary little- and big-endian): vertex positions, vertex normals
//! and texture coordinates when present, faces fan-triangulated; other elements and
//! properties are skipped.
//! Every count in the header is checked against the bytes the file holds before anything
//! is allocated from it. Errors name the file and the element (and item) at fault.

use glam::{Vec2, Vec3};
use std::path::Path;

use super::mesh::MeshData;

/// Longest header read, in bytes: a real header is a few hundred.
const MAX_HEADER: usize = 64 << 10;

/// A scalar type of the format.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Ty {
    fn parse(s: &str) -> Option<Ty> {
        Some(match s {
            "char" | "int8" => Ty::I8,
            "uchar" | "uint8" => Ty::U8,
            "short" | "int16" => Ty::I16,
            "ushort" | "uint16" => Ty::U16,
            "int" | "int32" => Ty::I32,
            "uint" | "uint32" => Ty::U32,
            "float" | "float32" => Ty::F32,
            "double" | "float64" => Ty::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 => 4,
            Ty::F64 => 8,
        }
    }
}

/// A property: a scalar, or a list with its count type.
#[derive(Clone, Debug)]
struct Prop {
    name: String,
    ty: Ty,
    list: Option<Ty>,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Prop>,
}

#[derive(Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Little,
    Big,
}

/// Reads the values of a PLY body in order, whatever its encoding.
struct Reader<'a> {
    body: &'a [u8],
    at: usize,
    format: Format,
}

impl Reader<'_> {
    fn value(&mut self, ty: Ty) -> Result<f64, String> {
        if self.format == Format::Ascii {
            while self.at < self.body.len() && self.body[self.at].is_ascii_whitespace() {
                self.at += 1;
            }
            let start = self.at;
            while self.at < self.body.len() && !self.body[self.at].is_ascii_whitespace() {
                self.at += 1;
            }
            if start == self.at {
                return Err("the file ends early".into());
            }
            let tok = std::str::from_utf8(&self.body[start..self.at]).unwrap_or("?");
            let v: f64 = tok.parse().map_err(|_| format!("`{tok}` is not a number"))?;
            let integral = !matches!(ty, Ty::F32 | Ty::F64);
            if integral && v.fract() != 0.0 {
                return Err(format!("`{tok}` is not an integer"));
            }
            return Ok(v);
        }
        let n = ty.size();
        let Some(b) = self.body.get(self.at..self.at + n) else { return Err("the file ends early".into()) };
        self.at += n;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(b);
        if self.format == Format::Big {
            a[..n].reverse();
        }
        Ok(match ty {
            Ty::I8 => a[0] as i8 as f64,
            Ty::U8 => a[0] as f64,
            Ty::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
            Ty::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
            Ty::I32 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Ty::U32 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Ty::F32 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Ty::F64 => f64::from_le_bytes(a),
        })
    }

    fn remaining(&self) -> usize {
        self.body.len() - self.at
    }
}

/// Parses the header: the format, the elements, and the byte offset of the body.
fn header(bytes: &[u8]) -> Result<(Format, Vec<Element>, usize), String> {
    let head = &bytes[..bytes.len().min(MAX_HEADER)];
    let mut at = 0;
    let mut lines = Vec::new();
    loop {
        let Some(nl) = head[at..].iter().position(|&b| b == b'\n') else {
            return Err(format!("no `end_header` line in the first {} KiB", MAX_HEADER >> 10));
        };
        let line = std::str::from_utf8(&head[at..at + nl]).map_err(|_| "the header is not text".to_string())?;
        at += nl + 1;
        let line = line.trim_end_matches('\r').trim();
        if line == "end_header" {
            break;
        }
        lines.push(line.to_string());
    }
    let mut it = lines.iter();
    if it.next().map(String::as_str) != Some("ply") {
        return Err("not a PLY file (the first line is not `ply`)".into());
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for (i, line) in it.enumerate() {
        let w: Vec<&str> = line.split_whitespace().collect();
        let bad = |what: &str| format!("header line {}: {what} (`{line}`)", i + 2);
        match w.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                format = Some(match w.get(1).copied() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::Little,
                    Some("binary_big_endian") => Format::Big,
                    _ => return Err(bad("unknown format")),
                });
            }
            Some("element") => {
                let (Some(name), Some(count), None) = (w.get(1), w.get(2), w.get(3)) else {
                    return Err(bad("expected `element NAME COUNT`"));
                };
                let count = count.parse().map_err(|_| bad("the count is not a non-negative integer"))?;
                elements.push(Element { name: name.to_string(), count, props: Vec::new() });
            }
            Some("property") => {
                let el = elements.last_mut().ok_or_else(|| bad("a property before any element"))?;
                let prop = match w[1..] {
                    ["list", c, t, name] => {
                        let c = Ty::parse(c).ok_or_else(|| bad("unknown count type"))?;
                        if matches!(c, Ty::F32 | Ty::F64) {
                            return Err(bad("a list count must be an integer type"));
                        }
                        Prop { name: name.into(), ty: Ty::parse(t).ok_or_else(|| bad("unknown type"))?, list: Some(c) }
                    }
                    [t, name] => {
                        Prop { name: name.into(), ty: Ty::parse(t).ok_or_else(|| bad("unknown type"))?, list: None }
                    }
                    _ => return Err(bad("expected `property TYPE NAME` or `property list COUNT_TYPE TYPE NAME`")),
                };
                el.props.push(prop);
            }
            Some(_) => return Err(bad("unknown header keyword")),
        }
    }
    Ok((format.ok_or("no `format` line in the header")?, elements, at))
}

/// Reads a PLY mesh.
pub fn load_ply(path: &Path) -> Result<MeshData, String> {
    let name = path.display();
    match std::fs::metadata(path) {
        Ok(m) if !m.is_file() => return Err(format!("mesh `{name}` is not a regular file")),
        _ => {}
    }
    let bytes = std::fs::read(path).map_err(|e| format!("cannot open mesh `{name}`: {e}"))?;
    parse_ply(&bytes).map_err(|e| format!("malformed PLY `{name}`: {e}"))
}

/// Parses PLY bytes (the file name is added by the caller).
pub fn parse_ply(bytes: &[u8]) -> Result<MeshData, String> {
    let (format, elements, body_at) = header(bytes)?;
    let mut r = Reader { body: &bytes[body_at..], at: 0, format };
    let mut out = MeshData::default();
    let mut faces_seen = false;
    for el in &elements {
        check_count(el, &r)?;
        let count = el.count as usize;
        let role = Role::of(el)?;
        match &role {
            Role::Vertex(layout) => {
                out.positions.reserve(count);
                if layout.normals.is_some() {
                    out.normals.reserve(count);
                }
                if layout.uvs.is_some() {
                    out.uvs.reserve(count);
                }
            }
            Role::Face(_) => faces_seen = true,
            Role::Other => {}
        }
        let index_prop = if let Role::Face(k) = role { Some(k) } else { None };
        let mut vals = vec![0.0f64; el.props.len()];
        let mut list: Vec<f64> = Vec::new();
        for item in 0..count {
            let at = |e: String| format!("element `{}` {item}: {e}", el.name);
            read_item(&mut r, el, index_prop, &mut vals, &mut list).map_err(at)?;
            match &role {
                Role::Vertex(layout) => push_vertex(&mut out, layout, &vals).map_err(at)?,
                Role::Face(_) => push_face(&mut out, &list).map_err(at)?,
                Role::Other => {}
            }
        }
    }
    if !faces_seen || out.triangles.is_empty() {
        return Err("no faces".into());
    }
    // Only with several `vertex` elements, some with texture coordinates and some without.
    if !out.uvs.is_empty() && out.uvs.len() != out.positions.len() {
        return Err("some `vertex` elements have texture coordinates and some do not".into());
    }
    Ok(out)
}

/// Refuses an element whose declared item count the rest of the file cannot hold, before
/// anything is reserved for it.
fn check_count(el: &Element, r: &Reader) -> Result<(), String> {
    // Each item takes at least this many bytes: its scalars (or one character and a
    // separator each in ascii), and each list's count.
    let min: usize = el
        .props
        .iter()
        .map(|p| if r.format == Format::Ascii { 2 } else { p.list.unwrap_or(p.ty).size() })
        .sum::<usize>()
        .max(1);
    // The last value may lack its trailing separator in ascii: hence the + 1.
    let fits = (r.remaining() + 1) / min;
    if el.count > fits as u64 {
        return Err(format!(
            "element `{}` declares {} items; the {} bytes after the header hold at most {fits}",
            el.name,
            el.count,
            r.remaining()
        ));
    }
    Ok(())
}

/// Where a vertex element's properties sit among its scalars.
struct VertexLayout {
    positions: [usize; 3],
    /// `nx`, `ny`, `nz` when all three are present.
    normals: Option<[usize; 3]>,
    /// The texture coordinates when a pair is present (see [`Role::of`]).
    uvs: Option<[usize; 2]>,
}

/// What an element contributes to the mesh.
enum Role {
    /// Positions, and normals and texture coordinates when present.
    Vertex(VertexLayout),
    /// Faces, from the list property at this index.
    Face(usize),
    /// Nothing: skipped.
    Other,
}

impl Role {
    /// The role of an element, refusing a vertex element without positions and a face
    /// element without indices. Texture coordinates are the first pair present of `u`/`v`,
    /// `texture_u`/`texture_v` and `s`/`t`, the names (and the order) Mitsuba's ply.cpp
    /// accepts.
    fn of(el: &Element) -> Result<Role, String> {
        let find = |n: &str| el.props.iter().position(|p| p.name == n && p.list.is_none());
        let pair = |a: &str, b: &str| Some([find(a)?, find(b)?]);
        if el.name == "vertex" {
            let (Some(x), Some(y), Some(z)) = (find("x"), find("y"), find("z")) else {
                return Err("element `vertex` lacks an x, y or z property".into());
            };
            let normals = (|| Some([find("nx")?, find("ny")?, find("nz")?]))();
            let uvs = pair("u", "v").or_else(|| pair("texture_u", "texture_v")).or_else(|| pair("s", "t"));
            return Ok(Role::Vertex(VertexLayout { positions: [x, y, z], normals, uvs }));
        }
        if el.name == "face" {
            let index_prop = el
                .props
                .iter()
                .position(|p| p.list.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index"));
            return index_prop
                .map(Role::Face)
                .ok_or_else(|| "element `face` has no `vertex_indices` (or `vertex_index`) list".into());
        }
        Ok(Role::Other)
    }
}

/// Reads one item's values: scalars into `vals` (by property index), the entries of the
/// list property `keep` into `list`; other lists are read and dropped.
fn read_item(
    r: &mut Reader,
    el: &Element,
    keep: Option<usize>,
    vals: &mut [f64],
    list: &mut Vec<f64>,
) -> Result<(), String> {
    for (k, p) in el.props.iter().enumerate() {
        match p.list {
            None => vals[k] = r.value(p.ty)?,
            Some(cty) => {
                let n = r.value(cty)?;
                let fits =
                    if r.format == Format::Ascii { r.remaining().div_ceil(2) } else { r.remaining() / p.ty.size() };
                if n < 0.0 || n > fits as f64 {
                    return Err(format!("list `{}` declares {n} entries; the file holds fewer", p.name));
                }
                let kept = Some(k) == keep;
                if kept {
                    list.clear();
                }
                for _ in 0..n as usize {
                    let v = r.value(p.ty)?;
                    if kept {
                        list.push(v);
                    }
                }
            }
        }
    }
    Ok(())
}

/// Appends a vertex item's position (and normal and texture coordinates).
fn push_vertex(out: &mut MeshData, layout: &VertexLayout, vals: &[f64]) -> Result<(), String> {
    let vec3 = |i: [usize; 3]| Vec3::new(vals[i[0]] as f32, vals[i[1]] as f32, vals[i[2]] as f32);
    let v = vec3(layout.positions);
    if !v.is_finite() {
        return Err("a vertex coordinate is not a finite f32".into());
    }
    out.positions.push(v);
    if let Some(nrm) = layout.normals {
        let n = vec3(nrm);
        if !n.is_finite() {
            return Err("a normal is not finite".into());
        }
        out.normals.push(n);
    }
    if let Some([u, v]) = layout.uvs {
        // Stored as read: Mitsuba's `flip_tex_coords` is false by default for PLY.
        let uv = Vec2::new(vals[u] as f32, vals[v] as f32);
        if !uv.is_finite() {
            return Err("a texture coordinate is not a finite f32".into());
        }
        out.uvs.push(uv);
    }
    Ok(())
}

/// Appends a face item's triangles (a fan around its first vertex).
fn push_face(out: &mut MeshData, list: &[f64]) -> Result<(), String> {
    if list.len() < 3 {
        return Err(format!("a face with {} vertices", list.len()));
    }
    let n = out.positions.len();
    let idx = |v: f64| -> Result<u32, String> {
        if v < 0.0 || v >= n as f64 {
            return Err(format!("vertex index {v} is out of range ({n} vertices read before the faces)"));
        }
        Ok(v as u32)
    };
    let first = idx(list[0])?;
    for w in list[1..].windows(2) {
        out.triangles.push([first, idx(w[0])?, idx(w[1])?]);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const ASCII: &str = "ply\nformat ascii 1.0\ncomment a unit square\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 1\n1 0 0 2\n1 1 0 3\n0 1 0 4\n4 0 1 2 3\n";

    fn binary(big: bool) -> Vec<u8> {
        let enc = if big { "binary_big_endian" } else { "binary_little_endian" };
        let mut b = format!("ply\r\nformat {enc} 1.0\r\nelement vertex 3\r\nproperty float32 x\r\nproperty float32 y\r\nproperty float32 z\r\nproperty float nx\r\nproperty float ny\r\nproperty float nz\r\nelement face 1\r\nproperty list uint8 uint32 vertex_index\r\nend_header\r\n").into_bytes();
        let f = |b: &mut Vec<u8>, x: f32| b.extend(if big { x.to_be_bytes() } else { x.to_le_bytes() });
        for v in [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]] {
            for x in v {
                f(&mut b, x);
            }
            for x in [0.0, 0.0, 1.0] {
                f(&mut b, x);
            }
        }
        b.push(3);
        for i in [0u32, 1, 2] {
            b.extend(if big { i.to_be_bytes() } else { i.to_le_bytes() });
        }
        b
    }

    #[test]
    fn ascii_quad_is_fanned_and_extra_properties_skipped() {
        let m = parse_ply(ASCII.as_bytes()).unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert!(m.normals.is_empty());
    }

    #[test]
    fn binary_both_endians_agree() {
        let (le, be) = (parse_ply(&binary(false)).unwrap(), parse_ply(&binary(true)).unwrap());
        assert_eq!(le, be);
        assert_eq!(le.positions[1], Vec3::new(2.0, 0.0, 0.0));
        assert_eq!(le.normals, vec![Vec3::Z; 3]);
        assert_eq!(le.triangles, vec![[0, 1, 2]]);
    }

    /// An ascii triangle whose vertices carry the properties `a` and `b`.
    fn with_uv(a: &str, b: &str) -> String {
        format!("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float {a}\nproperty float {b}\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 0.1 0.2\n1 0 0 0.9 0.3\n0 1 0 0.25 0.8\n3 0 1 2\n")
    }

    #[test]
    fn texture_coordinates_under_mitsubas_names_unflipped() {
        // Mitsuba 3.9.1 on these files: vertex_texcoords (0.1, 0.2), (0.9, 0.3),
        // (0.25, 0.8) for u/v, s/t and texture_u/texture_v (no flip); none for
        // texture_s/texture_t, which its ply.cpp does not accept.
        let want = [Vec2::new(0.1, 0.2), Vec2::new(0.9, 0.3), Vec2::new(0.25, 0.8)];
        for (a, b) in [("u", "v"), ("s", "t"), ("texture_u", "texture_v")] {
            let m = parse_ply(with_uv(a, b).as_bytes()).unwrap();
            assert_eq!(m.uvs, want, "{a}/{b}");
        }
        assert!(parse_ply(with_uv("texture_s", "texture_t").as_bytes()).unwrap().uvs.is_empty());
        assert!(parse_ply(with_uv("u", "t").as_bytes()).unwrap().uvs.is_empty());
        assert!(parse_ply(ASCII.as_bytes()).unwrap().uvs.is_empty());
        let bad = with_uv("u", "v").replace("0.9 0.3", "0.9 inf");
        assert!(parse_ply(bad.as_bytes()).unwrap_err().contains("element `vertex` 1: a texture coordinate"));
    }

    #[test]
    fn binary_texture_coordinates() {
        let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nproperty float s\nproperty float t\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n".to_vec();
        for (p, uv) in
            [([0.0f64, 0.0, 0.0], [0.5f32, 0.25]), ([1.0, 0.0, 0.0], [1.0, 0.0]), ([0.0, 1.0, 0.0], [0.0, 1.0])]
        {
            p.iter().for_each(|x| b.extend(x.to_le_bytes()));
            uv.iter().for_each(|x| b.extend(x.to_le_bytes()));
        }
        b.push(3);
        [0u32, 1, 2].iter().for_each(|i| b.extend(i.to_le_bytes()));
        let m = parse_ply(&b).unwrap();
        assert_eq!(m.uvs, vec![Vec2::new(0.5, 0.25), Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)]);
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn bad_counts_and_indices_are_refused_before_allocating() {
        let huge = ASCII.replace("element vertex 4", "element vertex 18446744073709551615");
        assert!(parse_ply(huge.as_bytes()).unwrap_err().contains("declares 18446744073709551615 items"));
        let mut b = binary(false);
        let n = b.len();
        b[n - 13] = 255; // the face's list count
        b.truncate(n - 12);
        let e = parse_ply(&b).unwrap_err();
        assert!(e.contains("element `face` 0"), "{e}");
        let out = ASCII.replace("4 0 1 2 3", "4 0 1 2 9");
        assert!(parse_ply(out.as_bytes()).unwrap_err().contains("vertex index 9 is out of range"));
        assert!(parse_ply(b"ply\nformat ascii 1.0\n").unwrap_err().contains("end_header"));
        let short = ASCII.replace("0 1 0 4\n4 0 1 2 3\n", "0 1 0 4\n4 0 1");
        assert!(parse_ply(short.as_bytes()).is_err());
    }
}
