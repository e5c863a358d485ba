//! Wavefront OBJ meshes through `tobj`: triangles only, positions checked.

use glam::Vec3;
use std::io::BufReader;
use std::path::Path;

/// Reads the triangles of an OBJ file (faces fan-triangulated by tobj), in object space.
/// Errors are messages to be placed after the field that named the file.
pub fn load_obj(path: &Path) -> Result<Vec<[Vec3; 3]>, String> {
    // A device or a pipe would be read without end or block for ever.
    match std::fs::metadata(path) {
        Ok(m) if !m.is_file() => return Err(format!("mesh `{}` is not a regular file", path.display())),
        _ => {}
    }
    let file = std::fs::File::open(path).map_err(|e| format!("cannot open mesh `{}`: {e}", path.display()))?;
    let opts = tobj::LoadOptions { triangulate: true, single_index: false, ignore_points: true, ignore_lines: true };
    // Materials are not used: never let tobj open .mtl files next to the mesh.
    let (models, _) = tobj::load_obj_buf(&mut BufReader::new(file), &opts, |_| Err(tobj::LoadError::OpenFileFailed))
        .map_err(|e| format!("malformed OBJ `{}`: {}", path.display(), describe(&e)))?;
    let mut tris = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let p = &m.positions;
        if let Some(bad) = p.iter().position(|x| !x.is_finite()) {
            return Err(format!(
                "malformed OBJ `{}`: vertex {} of object `{}` has a non-finite coordinate",
                path.display(),
                bad / 3 + 1,
                model.name
            ));
        }
        let vertex = |i: u32| -> Result<Vec3, String> {
            let i = i as usize;
            if 3 * i + 2 >= p.len() {
                return Err(format!("malformed OBJ `{}`: face refers to missing vertex {}", path.display(), i + 1));
            }
            Ok(Vec3::new(p[3 * i], p[3 * i + 1], p[3 * i + 2]))
        };
        for f in m.indices.chunks_exact(3) {
            tris.push([vertex(f[0])?, vertex(f[1])?, vertex(f[2])?]);
        }
    }
    if tris.is_empty() {
        return Err(format!("OBJ `{}` contains no triangles", path.display()));
    }
    Ok(tris)
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
