//! (d) Mitsuba XML scenes: line and attribute edits of the scenes in scenes/import, and
//! hostile constructs (entity definitions, deep nesting, include cycles, undefined
//! parameters, absurd sizes), loaded through `SceneSource::from_file` from a temporary
//! folder that holds the scenes' meshes.

use crate::harness::{cases, check_source, run_property, MAX_SCENE_BYTES, TINY};
use crate::values::{cap, odd_value};
use proptest::prelude::*;
use std::path::Path;
use wavetrace::scene::SceneSource;

const BASES: [&str; 3] = [
    include_str!("../../scenes/import/cbox.xml"),
    include_str!("../../scenes/import/torus.xml"),
    include_str!("../../scenes/import/instances.xml"),
];

/// One edit of the XML text; indices are taken modulo the current length.
#[derive(Clone, Debug)]
enum Edit {
    DeleteLine(prop::sample::Index),
    DuplicateLine(prop::sample::Index),
    SwapLines(prop::sample::Index, prop::sample::Index),
    /// Replaces the n-th quoted attribute value on a line.
    ReplaceValue(prop::sample::Index, prop::sample::Index, String),
    InsertLine(prop::sample::Index, String),
    DeleteChar(prop::sample::Index),
    InsertChar(prop::sample::Index, char),
    Truncate(prop::sample::Index),
}

/// Elements worth inserting: supported and unsupported plugins, bad values, and the
/// hostile constructs.
fn inserted() -> BoxedStrategy<String> {
    prop_oneof![
        6 => prop::sample::select(vec![
            "<shape type=\"disk\"/>",
            "<shape type=\"sphere\"><float name=\"radius\" value=\"1e38\"/></shape>",
            "<shape type=\"sphere\"><transform name=\"to_world\"><scale x=\"0\"/></transform></shape>",
            "<shape type=\"cube\"><emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>",
            "<shape type=\"rectangle\"><transform name=\"to_world\"><matrix value=\"1 2 3\"/></transform></shape>",
            "<shape type=\"rectangle\"><transform name=\"to_world\"><matrix value=\"0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 1\"/></transform></shape>",
            "<shape type=\"instance\"><ref id=\"nothing\"/></shape>",
            "<shape type=\"shapegroup\" id=\"g\"><shape type=\"instance\"><ref id=\"g\"/></shape></shape>",
            "<shape type=\"obj\"><string name=\"filename\" value=\"/dev/zero\"/></shape>",
            "<shape type=\"ply\"><string name=\"filename\" value=\"scene.xml\"/></shape>",
            "<shape type=\"obj\"><string name=\"filename\" value=\"meshes\"/></shape>",
            "<bsdf type=\"plastic\" id=\"p\"/>",
            "<bsdf type=\"dielectric\" id=\"d\"><string name=\"int_ior\" value=\"unobtainium\"/></bsdf>",
            "<emitter type=\"point\"><rgb name=\"intensity\" value=\"-1, 2\"/></emitter>",
            "<emitter type=\"spot\"/>",
            "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"nan\"/></emitter>",
            "<texture type=\"bitmap\"/>",
            "<include filename=\"scene.xml\"/>",
            "<include filename=\"../../../../etc/passwd\"/>",
            "<default name=\"spp\" value=\"99999999999\"/>",
            "<integer name=\"width\" value=\"$undefined\"/>",
            "<sensor type=\"orthographic\"/>",
            "<integrator type=\"path\"><integer name=\"max_depth\" value=\"-7\"/></integrator>",
            "<!DOCTYPE scene [<!ENTITY a \"aaaaaaaaaaaa\"><!ENTITY b \"&a;&a;&a;&a;&a;&a;\">]>",
            "&b;",
            "<![CDATA[ junk ]]>",
            "<?xml version=\"1.0\"?>",
            "</scene>",
            "<scene version=\"3.0.0\">",
        ])
        .prop_map(String::from),
        1 => (1usize..400).prop_map(|n| format!("{}{}", "<shape type=\"sphere\">".repeat(n), "</shape>".repeat(n))),
        1 => any::<String>().prop_map(|s| s.replace('\n', " ")),
    ]
    .boxed()
}

fn edit() -> BoxedStrategy<Edit> {
    let i = any::<prop::sample::Index>;
    let value = prop_oneof![
        4 => odd_value(),
        2 => prop::sample::select(vec!["0", "-1", "1e39", "4294967296", "18446744073709551616", "nan", "inf", "", "$res", "$nope", "true", "1, 2", "1 2 3 4", "0, 0, 0"]).prop_map(String::from),
    ];
    prop_oneof![
        3 => i().prop_map(Edit::DeleteLine),
        2 => i().prop_map(Edit::DuplicateLine),
        2 => (i(), i()).prop_map(|(a, b)| Edit::SwapLines(a, b)),
        6 => (i(), i(), value).prop_map(|(l, n, v)| Edit::ReplaceValue(l, n, v)),
        4 => (i(), inserted()).prop_map(|(a, s)| Edit::InsertLine(a, s)),
        1 => i().prop_map(Edit::DeleteChar),
        1 => (i(), any::<char>()).prop_map(|(a, c)| Edit::InsertChar(a, c)),
        1 => i().prop_map(Edit::Truncate),
    ]
    .boxed()
}

fn apply(text: &str, edits: &[Edit]) -> String {
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    for e in edits {
        let n = lines.len().max(1);
        match e {
            Edit::DeleteLine(i) if !lines.is_empty() => drop(lines.remove(i.index(n))),
            Edit::DuplicateLine(i) if !lines.is_empty() => {
                let l = lines[i.index(n)].clone();
                lines.insert(i.index(n), l);
            }
            Edit::SwapLines(a, b) if !lines.is_empty() => lines.swap(a.index(n), b.index(n)),
            Edit::ReplaceValue(l, k, v) if !lines.is_empty() => {
                let line = &mut lines[l.index(n)];
                let quotes: Vec<usize> = line.match_indices('"').map(|(p, _)| p).collect();
                if quotes.len() >= 2 {
                    let k = k.index(quotes.len() / 2);
                    let (a, b) = (quotes[2 * k], quotes[2 * k + 1]);
                    line.replace_range(a + 1..b, v);
                }
            }
            Edit::InsertLine(i, s) => lines.insert(i.index(n + 1).min(lines.len()), s.clone()),
            Edit::DeleteChar(i) | Edit::InsertChar(i, _) | Edit::Truncate(i) => {
                let mut t = lines.join("\n");
                let chars: Vec<(usize, char)> = t.char_indices().collect();
                if !chars.is_empty() {
                    let (at, _) = chars[i.index(chars.len())];
                    match e {
                        Edit::DeleteChar(_) => drop(t.remove(at)),
                        Edit::InsertChar(_, ch) => t.insert(at, *ch),
                        _ => t.truncate(at),
                    }
                }
                lines = t.lines().map(String::from).collect();
            }
            _ => {}
        }
    }
    lines.join("\n")
}

/// Copies what the base scenes refer to (meshes, the included materials) into `dir`.
fn stage(dir: &Path) {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/import");
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    for m in std::fs::read_dir(src.join("meshes")).unwrap() {
        let m = m.unwrap().path();
        std::fs::copy(&m, dir.join("meshes").join(m.file_name().unwrap())).unwrap();
    }
    std::fs::copy(src.join("materials.xml"), dir.join("materials.xml")).unwrap();
}

#[test]
fn xml_scene() {
    let dir = tempfile::tempdir().unwrap();
    stage(dir.path());
    let path = dir.path().join("scene.xml");
    let strategy = (0..BASES.len(), prop::collection::vec(edit(), 0..8));
    let c = run_property("xml_scene", strategy, |(base, edits)| {
        let text = cap(apply(BASES[*base], edits), MAX_SCENE_BYTES);
        std::fs::write(&path, &text).map_err(|e| format!("cannot write the scene: {e}"))?;
        let src = SceneSource::from_file(&path).map_err(|e| format!("from_file: {e}"))?;
        check_source(src, &TINY.map(String::from))
    });
    if cases() >= 100 {
        assert!(c.rendered > 0, "no edited scene rendered: the edits no longer leave valid scenes");
        assert!(c.rejected > 0, "no edited scene was rejected: the edits no longer reach the errors");
    }
}
