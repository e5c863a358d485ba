//! The command line on imported scenes: `.xml` picks the importer, `-D` sets parameters,
//! notes go to stderr, and every bad input exits 2 with no output file.

use std::process::Command;

use crate::{xml_scene, Files};

const BIN: &str = env!("CARGO_BIN_EXE_wavetrace");

fn run(f: &Files, args: &[&str]) -> (i32, String) {
    let o = Command::new(BIN).args(args).current_dir(f.dir()).output().expect("run wavetrace");
    (o.status.code().unwrap_or(-1), String::from_utf8_lossy(&o.stderr).into_owned())
}

#[test]
fn xml_renders_with_defines_and_notes() {
    let f = Files::temp();
    let body = "<default name=\"r\" value=\"1\"/><integrator type=\"path\"/>\
                <emitter type=\"area\" id=\"unused\"><rgb name=\"radiance\" value=\"1\"/></emitter>\
                <shape type=\"sphere\"><float name=\"radius\" value=\"$r\"/></shape>\
                <emitter type=\"point\"><point name=\"position\" z=\"4\"/></emitter>";
    f.write("s.xml", xml_scene(body));
    let (code, err) = run(&f, &["render", "s.xml", "-D", "r=0.5", "-o", "out.png", "--quiet"]);
    assert_eq!(code, 0, "{err}");
    assert!(f.dir().join("out.png").exists());
    let (code, err) = run(&f, &["render", "s.xml", "-o", "out2.png"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("is named by no <ref>"), "{err}");
    // The notes are part of the stats too: the table and the JSON.
    let o = Command::new(BIN)
        .args(["render", "s.xml", "-o", "out3.png", "--stats", "--stats-json", "s.json"])
        .current_dir(f.dir())
        .output()
        .expect("run wavetrace");
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(table.contains("is named by no <ref>"), "{table}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(f.dir().join("s.json")).unwrap()).unwrap();
    let notes = json["scene"]["notes"].as_array().expect("scene.notes");
    assert!(notes.iter().any(|n| n.as_str().unwrap().contains("named by no <ref>")), "{notes:?}");
    // The transport the integrator asked for, named by the summary and the JSON
    // (Mitsuba's unbounded depth imports as 64 bounces).
    assert!(table.contains(" path (max_depth 64): "), "{table}");
    assert_eq!((json["transport"].as_str(), json["max_depth"].as_u64()), (Some("path"), Some(64)), "{json}");
}

#[test]
fn bad_imports_exit_2_with_no_output() {
    let f = Files::temp();
    f.write("bad.xml", xml_scene("<shape type=\"cylinder\"/>"));
    f.write("s.toml", "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n");
    f.write("good.xml", xml_scene(""));
    for (args, needle) in [
        (&["render", "bad.xml", "-o", "o.png"][..], "bad.xml:7:1: <shape type=\"cylinder\">: not supported"),
        (&["render", "good.xml", "-D", "novalue", "-o", "o.png"][..], "-D `novalue`: expected NAME=VALUE"),
        (&["render", "s.toml", "-D", "a=1", "-o", "o.png"][..], "use --set for TOML"),
        (&["render", "missing.xml", "-o", "o.png"][..], "missing.xml"),
    ] {
        let (code, err) = run(&f, args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: `{needle}` not in {err}");
        assert!(!f.dir().join("o.png").exists(), "{args:?} left an output");
    }
}
