//! Import (issue 14): Mitsuba 3 XML scenes, PLY meshes, lights on triangles, transforms
//! and smooth normals. One module per concern: the XML reader and plugin mapping with
//! its error messages (`xml`), camera and transform conversions against hand-computed
//! values (`conversions`), triangle and rectangle lights against Lambert's closed form
//! (`lights`), meshes: PLY, smooth normals, emissive meshes (`meshes`), and the same scene
//! in TOML and XML (`same_scene`). Renders are tiny so the crate stays fast.

#[path = "../support/mod.rs"]
mod support;

mod cli;
mod conversions;
mod lights;
mod meshes;
mod plugins;
mod same_scene;
mod xml;

use std::path::{Path, PathBuf};
use wavetrace::scene::{load, SceneSource};
use wavetrace::{Error, Scene};

/// A folder of scene files for one test.
pub struct Files {
    dir: tempfile::TempDir,
}

impl Files {
    /// An empty folder.
    pub fn temp() -> Files {
        Files { dir: tempfile::tempdir().expect("tempdir") }
    }

    /// Writes `text` (or bytes) to `name` in the folder; returns its path.
    pub fn write(&self, name: &str, text: impl AsRef<[u8]>) -> PathBuf {
        let p = self.dir.path().join(name);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).expect("mkdir");
        }
        std::fs::write(&p, text).expect("write");
        p
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        self.dir.path()
    }
}

/// Loads a scene file (TOML or XML by extension) with `-D` parameters and `--set`s.
pub fn try_load(path: &Path, defines: &[(&str, &str)], sets: &[&str]) -> wavetrace::Result<Scene> {
    let mut src = SceneSource::from_file(path)?;
    src.defines = defines.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    load(&src, &sets)
}

/// Loads a scene file; panics with the error.
pub fn load_file(path: &Path) -> Scene {
    try_load(path, &[], &[]).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The input-error message of loading `path`; panics if it loads or fails otherwise.
pub fn error_of(path: &Path, defines: &[(&str, &str)]) -> String {
    match try_load(path, defines, &[]) {
        Err(Error::Input(m)) => m,
        Err(e) => panic!("not an input error: {e}"),
        Ok(_) => panic!("{} loaded", path.display()),
    }
}

/// An XML scene: a 4×4 perspective sensor plus `body`.
pub fn xml_scene(body: &str) -> String {
    format!(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\">\n<float name=\"fov\" value=\"40\"/>\n\
         <transform name=\"to_world\"><lookat origin=\"0, 0, 5\" target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>\n\
         <film type=\"hdrfilm\"><integer name=\"width\" value=\"4\"/><integer name=\"height\" value=\"4\"/></film>\n\
         </sensor>\n{body}\n</scene>\n"
    )
}

/// The crate's scenes/import folder.
pub fn import_scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join("import")
}
