//! The scene's mesh files, read and parsed a few at a time in parallel, ahead of the
//! objects that use them, and each file once however many objects place it. The objects
//! are still built one after the other, in the file's order, so the scene is the same
//! bits as when each object read its own file.

use rayon::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::scene::mesh::{self, MeshData};
use crate::system::available_memory;

/// A mesh file read, or why it could not be.
pub(super) type Loaded = Arc<std::result::Result<MeshData, String>>;

/// The mesh files of a scene's objects, in the order the objects first use them.
pub(super) struct Meshes {
    /// Distinct files, in order of first use.
    order: Vec<PathBuf>,
    /// How many more objects will ask for each file.
    uses: HashMap<PathBuf, usize>,
    /// Files read and still wanted.
    ready: HashMap<PathBuf, Loaded>,
    /// The next file of `order` to read.
    next: usize,
}

impl Meshes {
    /// The files `paths` (one per mesh object, in object order) will be asked for.
    pub(super) fn new(paths: impl IntoIterator<Item = PathBuf>) -> Meshes {
        let (mut order, mut uses) = (Vec::new(), HashMap::new());
        for p in paths {
            let n: &mut usize = uses.entry(p.clone()).or_default();
            if *n == 0 {
                order.push(p);
            }
            *n += 1;
        }
        Meshes { order, uses, ready: HashMap::new(), next: 0 }
    }

    /// The mesh of file `path`, for the next object that uses it: read with the files after
    /// it (one per thread, as long as their estimated memory together stays within what
    /// [`check_mesh_size`] allows one file) if it is not yet, and forgotten after its
    /// last use.
    pub(super) fn take(&mut self, path: &Path) -> Loaded {
        if !self.ready.contains_key(path) {
            self.read_ahead(path);
        }
        let loaded = self.ready.get(path).cloned().unwrap_or_else(|| Arc::new(read(path)));
        if let Some(n) = self.uses.get_mut(path) {
            *n = n.saturating_sub(1);
            if *n == 0 {
                self.ready.remove(path);
            }
        }
        loaded
    }

    /// Reads `path` and the files after it in first-use order, in parallel.
    fn read_ahead(&mut self, path: &Path) {
        let Some(at) = self.order[self.next..].iter().position(|p| p == path) else { return };
        let start = self.next + at;
        let (budget, threads) = (available_memory() / 2, rayon::current_num_threads().max(1));
        let mut end = start + 1;
        let mut need = estimated_bytes(path);
        while end < self.order.len() && end - start < threads {
            need = need.saturating_add(estimated_bytes(&self.order[end]));
            if need > budget {
                break;
            }
            end += 1;
        }
        let read: Vec<Loaded> = self.order[start..end].par_iter().map(|p| Arc::new(read(p))).collect();
        for (p, loaded) in self.order[start..end].iter().zip(read) {
            self.ready.insert(p.clone(), loaded);
        }
        self.next = end;
    }
}

/// Memory a mesh costs per byte of OBJ text: tobj's buffers, our triangles (36 bytes
/// per 3 indices of about 10 text bytes) and about two 48-byte BVH nodes per triangle,
/// with margin.
const MESH_BYTES_PER_TEXT_BYTE: u64 = 16;

/// The memory reading file `path` may take (0 when it cannot be read: reading says why).
fn estimated_bytes(path: &Path) -> u64 {
    std::fs::metadata(path).map_or(0, |m| m.len().saturating_mul(MESH_BYTES_PER_TEXT_BYTE))
}

/// Refuses, before reading it, a mesh whose file is too large for the memory available.
fn check_mesh_size(path: &Path) -> std::result::Result<(), String> {
    let Ok(meta) = std::fs::metadata(path) else { return Ok(()) }; // load_obj reports it
    let need = meta.len().saturating_mul(MESH_BYTES_PER_TEXT_BYTE);
    let have = available_memory();
    if need > have / 2 {
        return Err(format!(
            "mesh `{}` ({:.1} MiB of text) would need about {:.1} GiB of memory; {:.1} GiB is available (at most half may be used)",
            path.display(),
            meta.len() as f64 / (1u64 << 20) as f64,
            need as f64 / (1u64 << 30) as f64,
            have as f64 / (1u64 << 30) as f64
        ));
    }
    Ok(())
}

/// Checks and reads a mesh file, OBJ or PLY by its extension (`.ply`, case-insensitive;
/// anything else is read as OBJ).
fn read(path: &Path) -> std::result::Result<MeshData, String> {
    check_mesh_size(path)?;
    let ply = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("ply"));
    if ply {
        crate::scene::ply::load_ply(path)
    } else {
        mesh::load_obj_mesh(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_file_is_read_once_and_kept_until_its_last_use() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let tri = |d: f32| format!("v 0 0 0\nv 1 0 0\nv 0 {d} 1\nf 1 2 3\n");
        let (a, b, bad) = (dir.path().join("a.obj"), dir.path().join("b.obj"), dir.path().join("missing.obj"));
        std::fs::write(&a, tri(1.0)).unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(&b, tri(2.0)).unwrap_or_else(|e| panic!("{e}"));
        let mut m = Meshes::new([a.clone(), b.clone(), a.clone(), bad.clone()]);
        let first = m.take(&a);
        assert_eq!(first.as_ref().as_ref().map(|m| m.positions[2].y), Ok(1.0));
        assert!(m.ready.contains_key(&a), "a is used again");
        let second = m.take(&b);
        assert_eq!(second.as_ref().as_ref().map(|m| m.positions[2].y), Ok(2.0));
        assert!(!m.ready.contains_key(&b), "b's last use");
        let again = m.take(&a);
        assert!(Arc::ptr_eq(&first, &again), "a read once");
        assert!(!m.ready.contains_key(&a), "a's last use");
        let err = m.take(&bad);
        assert!(err.as_ref().as_ref().is_err_and(|e| e.contains("missing.obj")), "{err:?}");
        assert!(m.ready.is_empty());
    }
}
