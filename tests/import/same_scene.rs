//! The same scene written in TOML and in Mitsuba XML renders bit-identically: the
//! mapping of sensors, rectangles, BSDFs, spheres and an emissive OBJ luminaire adds no
//! rounding of its own.

use wavetrace::{render, RenderOptions};

use crate::{import_scenes, try_load};

#[test]
fn cornell_box_in_toml_and_xml_renders_bit_identically() {
    let dir = import_scenes();
    let sets = ["render.width=24", "render.height=24", "render.aa.samples=2", "render.shadows.samples=4"];
    let opts = RenderOptions { threads: Some(2), ..Default::default() };
    let toml = render(&try_load(&dir.join("cbox.toml"), &[], &sets).unwrap(), &opts).unwrap();
    let xml = render(&try_load(&dir.join("cbox.xml"), &[], &sets).unwrap(), &opts).unwrap();
    assert!(toml.image.pixels.iter().any(|p| p.max_element() > 0.0));
    assert_eq!(toml.image.pixels, xml.image.pixels);
    // Adaptive shadows too (the triangle probes of the emissive mesh).
    let adaptive: Vec<&str> = sets.iter().copied().chain(["render.shadows.mode=adaptive"]).collect();
    let toml = render(&try_load(&dir.join("cbox.toml"), &[], &adaptive).unwrap(), &opts).unwrap();
    let xml = render(&try_load(&dir.join("cbox.xml"), &[], &adaptive).unwrap(), &opts).unwrap();
    assert_eq!(toml.image.pixels, xml.image.pixels);
}

#[test]
fn every_import_scene_loads() {
    for entry in std::fs::read_dir(import_scenes()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "xml" || e == "toml") && !path.ends_with("materials.xml") {
            let scene = try_load(&path, &[], &["render.width=8", "render.height=8"]);
            assert!(scene.is_ok(), "{}: {}", path.display(), scene.err().unwrap());
        }
    }
}
