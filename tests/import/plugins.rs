//! Issue 29's import: `<ref>` resolved by the referenced element's kind (forward, across
//! includes, area emitters by id), the conductor, roughconductor and roughdielectric
//! BSDFs and the bitmap and checkerboard textures, tested on the `SceneFile` the importer
//! returns (the loader's checks of these materials are the loader's tests), and the
//! rectangle's UV convention.

use std::path::Path;

use wavetrace::scene::format::{ColorDesc, LightDesc, MaterialDesc, ObjectDesc, TextureDesc, TransformOp};
use wavetrace::scene::mitsuba::{import, Imported};
use wavetrace::Error;

use crate::{load_file, xml_scene, Files};

/// Imports `path`; panics with the error.
fn imported(path: &Path) -> Imported {
    import(path, &[]).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The input-error message of importing `path`.
fn import_error(path: &Path) -> String {
    match import(path, &[]) {
        Err(Error::Input(m)) => m,
        Err(e) => panic!("not an input error: {e}"),
        Ok(_) => panic!("{} imported", path.display()),
    }
}

/// The imported scene of `xml_scene(body)`.
fn scene_of(body: &str) -> Imported {
    let f = Files::temp();
    imported(&f.write("s.xml", xml_scene(body)))
}

/// The error of importing `xml_scene(body)`; the file is `s.xml`, the body starts on line 7.
fn error_of_body(body: &str) -> String {
    let f = Files::temp();
    import_error(&f.write("s.xml", xml_scene(body)))
}

/// Material `name` of a scene.
fn material(s: &Imported, name: &str) -> serde_json::Value {
    let m = s.file.materials.get(name).unwrap_or_else(|| panic!("no material `{name}` in {:?}", s.file.materials));
    serde_json::to_value(m).expect("json")
}

/// `MaterialDesc` has no `PartialEq`: compared by its serialized form.
fn json(m: MaterialDesc) -> serde_json::Value {
    serde_json::to_value(m).expect("json")
}

#[allow(clippy::too_many_arguments)] // reason: a test helper spelling out all eight fields of the variant
fn conductor(
    material: Option<&str>,
    eta: Option<[f32; 3]>,
    k: Option<[f32; 3]>,
    color: ColorDesc,
    distribution: Option<&str>,
    alpha: Option<f32>,
    alpha_u: Option<f32>,
    alpha_v: Option<f32>,
) -> serde_json::Value {
    json(MaterialDesc::Conductor {
        material: material.map(str::to_string),
        eta,
        k,
        color,
        distribution: distribution.map(str::to_string),
        alpha,
        alpha_u,
        alpha_v,
    })
}

#[test]
fn a_shape_takes_an_area_emitter_declared_after_it_by_id() {
    // The file Mitsuba 3.9.1 loads (`mi.load_file`: 2 shapes, 1 area light), where the
    // importer used to count the emitter's <ref> as a second BSDF.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/import/data/area-ref.xml");
    let s = imported(&path);
    match &s.file.lights[..] {
        [LightDesc::Quad { corner, edge_u, edge_v, radiance, .. }] => {
            assert_eq!((*corner, *edge_u, *edge_v), ([-1.0, -1.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]));
            assert_eq!(*radiance, [1.0, 2.0, 3.0]);
        }
        other => panic!("{other:?}"),
    }
    // The emitting rectangle is a light only; the sphere takes the BSDF declared last.
    assert!(matches!(&s.file.objects[..], [ObjectDesc::Sphere { material, .. }] if material == "white"));
    // And it renders through the loader.
    let scene = load_file(&path);
    assert_eq!(scene.lights.len(), 1);
}

#[test]
fn references_resolve_across_includes_and_emitters_attach_once() {
    let f = Files::temp();
    // Declared in an include that comes after the shapes that name them.
    f.write(
        "lib/decls.xml",
        "<scene version=\"3.0.0\">\n<emitter type=\"area\" id=\"lamp\"><rgb name=\"radiance\" value=\"4\"/></emitter>\n\
         <bsdf type=\"twosided\" id=\"metal\"><bsdf type=\"roughconductor\"><string name=\"material\" value=\"Cu\"/></bsdf></bsdf>\n\
         <emitter type=\"area\" id=\"spare\"><rgb name=\"radiance\" value=\"1\"/></emitter>\n</scene>\n",
    );
    let body = "<shape type=\"cube\"><ref id=\"lamp\"/></shape>\n<shape type=\"sphere\"><ref id=\"metal\"/></shape>\n\
                <include filename=\"lib/decls.xml\"/>";
    let s = imported(&f.write("s.xml", xml_scene(body)));
    assert_eq!(s.file.lights.len(), 6, "a cube light is six quads");
    assert_eq!(
        material(&s, "metal"),
        conductor(Some("Cu"), None, None, ColorDesc::Rgb([1.0; 3]), Some("beckmann"), Some(0.1), None, None)
    );
    // A declared area emitter that no shape names lights nothing, in Mitsuba too.
    assert!(
        s.notes.iter().any(|n| n.contains("decls.xml:4: <emitter type=\"area\"> id=\"spare\" is named by no <ref>")),
        "{:?}",
        s.notes
    );
    // Mitsuba: "an endpoint can be only be attached to a single shape".
    let body = "<emitter type=\"area\" id=\"e\"><rgb name=\"radiance\" value=\"1\"/></emitter>\n\
                <shape type=\"rectangle\"><ref id=\"e\"/></shape>\n<shape type=\"rectangle\"><ref id=\"e\"/></shape>";
    let msg = error_of_body(body);
    assert!(msg.contains("s.xml:9:1: <shape type=\"rectangle\">: <emitter type=\"area\" id=\"e\"> is already attached to the shape at"), "{msg}");
    assert!(msg.contains("s.xml:8:1"), "{msg}");
    // Two emitters on one shape, nested and referenced.
    let body = "<emitter type=\"area\" id=\"e\"><rgb name=\"radiance\" value=\"1\"/></emitter>\n\
                <shape type=\"rectangle\"><ref id=\"e\"/><emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>";
    assert!(error_of_body(body).contains("s.xml:8:1: <shape type=\"rectangle\">: more than one emitter"));
    // An area emitter at the top level without an id can attach to nothing.
    let msg = error_of_body("<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter>");
    assert!(msg.contains("s.xml:7:1: <emitter type=\"area\"> must be inside a <shape>, or have an id"), "{msg}");
}

#[test]
fn a_ref_to_an_unknown_id_or_a_wrong_kind_names_both_places() {
    let f = Files::temp();
    let msg = error_of_body("<shape type=\"sphere\"><ref id=\"nope\"/></shape>");
    assert!(msg.contains("s.xml:7:22: <ref id=\"nope\">: no element has id \"nope\" (a shape takes a <bsdf> or an <emitter type=\"area\">)"), "{msg}");
    // A texture where a shape wants a BSDF or an emitter: the ref's place and the texture's.
    f.write("inc.xml", "<scene version=\"3.0.0\">\n\n<texture type=\"checkerboard\" id=\"tx\"/>\n</scene>\n");
    let body = "<shape type=\"sphere\"><ref id=\"tx\"/></shape>\n<include filename=\"inc.xml\"/>";
    let msg = import_error(&f.write("k.xml", xml_scene(body)));
    assert!(
        msg.contains("k.xml:7:22: <ref id=\"tx\">: \"tx\" is the <texture type=\"checkerboard\"> declared at "),
        "{msg}"
    );
    assert!(msg.contains("inc.xml:3:1, and a shape takes a <bsdf> or an <emitter type=\"area\">"), "{msg}");
    // A BSDF where a diffuse wants a texture.
    let body = "<bsdf type=\"diffuse\" id=\"d\"><ref name=\"reflectance\" id=\"b\"/></bsdf>\n<bsdf type=\"diffuse\" id=\"b\"/>";
    let msg = error_of_body(body);
    assert!(msg.contains("s.xml:7:29: <ref id=\"b\">: \"b\" is the <bsdf type=\"diffuse\"> declared at"), "{msg}");
    assert!(msg.contains("s.xml:8:1, and `reflectance` takes a <texture>"), "{msg}");
    // A point light on a shape, and a sphere where an instance wants a shape group.
    let body = "<emitter type=\"point\" id=\"p\"/>\n<shape type=\"rectangle\"><ref id=\"p\"/></shape>\n\
                <shape type=\"sphere\" id=\"s\"/>\n<shape type=\"instance\"><ref id=\"s\"/></shape>";
    let msg = error_of_body(body);
    assert!(msg.contains("s.xml:8:25: <ref id=\"p\">: \"p\" is the <emitter type=\"point\"> declared at "), "{msg}");
    assert!(msg.contains("s.xml:7:1, and a shape takes a <bsdf>"), "{msg}");
    assert!(msg.contains("s.xml:10:24: <ref id=\"s\">: \"s\" is the <shape type=\"sphere\"> declared at "), "{msg}");
    assert!(msg.contains("s.xml:9:1, and an instance takes a <shape type=\"shapegroup\">"), "{msg}");
    // A twosided names its BSDF by id too; one that names itself ends.
    let s = scene_of("<bsdf type=\"twosided\" id=\"t\"><ref id=\"g\"/></bsdf>\n<bsdf type=\"dielectric\" id=\"g\"/>");
    assert!(material(&s, "t")["type"] == "dielectric");
    let msg = error_of_body("<bsdf type=\"twosided\" id=\"t\"><ref id=\"t\"/></bsdf>");
    assert!(msg.contains("twosided BSDFs nest deeper than 16"), "{msg}");
}

#[test]
fn conductors_map_to_named_metals_indices_or_mirrors() {
    let body = "<bsdf type=\"conductor\" id=\"gold\"><string name=\"material\" value=\"Au\"/></bsdf>\n\
                <bsdf type=\"conductor\" id=\"eta-k\"><rgb name=\"eta\" value=\"0.2, 0.9, 1.1\"/><spectrum name=\"k\" value=\"3\"/></bsdf>\n\
                <bsdf type=\"conductor\" id=\"eta-only\"><float name=\"eta\" value=\"2\"/></bsdf>\n\
                <bsdf type=\"conductor\" id=\"mirror\"><string name=\"material\" value=\"none\"/><rgb name=\"specular_reflectance\" value=\"0.9, 0.8, 0.7\"/></bsdf>\n\
                <bsdf type=\"conductor\" id=\"checked\"><texture type=\"checkerboard\" name=\"specular_reflectance\"/></bsdf>\n\
                <bsdf type=\"roughconductor\" id=\"rough\"/>\n\
                <bsdf type=\"roughconductor\" id=\"aniso\"><string name=\"distribution\" value=\"GGX\"/><float name=\"alpha_u\" value=\"0.05\"/><float name=\"alpha_v\" value=\"0.3\"/><string name=\"material\" value=\"Cu\"/><boolean name=\"sample_visible\" value=\"false\"/></bsdf>\n\
                <bsdf type=\"twosided\" id=\"both\"><bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"0.25\"/><string name=\"distribution\" value=\"ggx\"/></bsdf></bsdf>";
    let s = scene_of(body);
    let white = || ColorDesc::Rgb([1.0; 3]);
    assert_eq!(material(&s, "gold"), conductor(Some("Au"), None, None, white(), None, None, None, None));
    // eta and k instead of a name; Mitsuba's defaults fill the one not given (eta 0, k 1).
    assert_eq!(
        material(&s, "eta-k"),
        conductor(None, Some([0.2, 0.9, 1.1]), Some([3.0; 3]), white(), None, None, None, None)
    );
    assert_eq!(
        material(&s, "eta-only"),
        conductor(None, Some([2.0; 3]), Some([1.0; 3]), white(), None, None, None, None)
    );
    // Smooth, no index, an RGB reflectance: the perfect mirror it always was.
    assert_eq!(material(&s, "mirror"), json(MaterialDesc::Mirror { color: [0.9, 0.8, 0.7] }));
    let checks = ColorDesc::Texture(TextureDesc::Checkerboard { color0: [0.4; 3], color1: [0.2; 3], to_uv: None });
    assert_eq!(material(&s, "checked"), conductor(Some("none"), None, None, checks, None, None, None, None));
    // Mitsuba's roughconductor defaults: beckmann, alpha 0.1, the perfect reflector.
    assert_eq!(
        material(&s, "rough"),
        conductor(Some("none"), None, None, white(), Some("beckmann"), Some(0.1), None, None)
    );
    assert_eq!(
        material(&s, "aniso"),
        conductor(Some("Cu"), None, None, white(), Some("ggx"), None, Some(0.05), Some(0.3))
    );
    assert_eq!(material(&s, "both"), conductor(Some("none"), None, None, white(), Some("ggx"), Some(0.25), None, None));
    assert!(s.notes.iter().any(|n| n.contains("sample_visible=false is ignored")), "{:?}", s.notes);
}

#[test]
fn rough_dielectrics_keep_the_dielectric_rules() {
    let body = "<bsdf type=\"roughdielectric\" id=\"frosted\"><string name=\"int_ior\" value=\"water\"/><float name=\"ext_ior\" value=\"1\"/><string name=\"distribution\" value=\"ggx\"/><float name=\"alpha\" value=\"0.3\"/><rgb name=\"specular_transmittance\" value=\"0.9, 0.8, 0.7\"/></bsdf>\n\
                <bsdf type=\"roughdielectric\" id=\"plain\"/>";
    let s = scene_of(body);
    let glass = |ior: f32, color: [f32; 3], alpha: f32, distribution: &str| {
        json(MaterialDesc::Dielectric {
            ior,
            reflect_ratio: None,
            color,
            thin: false,
            distribution: Some(distribution.to_string()),
            alpha: Some(alpha),
            alpha_u: None,
            alpha_v: None,
        })
    };
    assert_eq!(material(&s, "frosted"), glass(1.333, [0.9, 0.8, 0.7], 0.3, "ggx"));
    assert_eq!(material(&s, "plain"), glass(1.5046 / 1.00028, [1.0; 3], 0.1, "beckmann"));
    let msg = error_of_body(
        "<bsdf type=\"roughdielectric\" id=\"r\"><rgb name=\"specular_reflectance\" value=\"0.5\"/></bsdf>",
    );
    assert!(
        msg.contains("s.xml:7:37: <bsdf type=\"roughdielectric\">: specular_reflectance other than 1 is not supported"),
        "{msg}"
    );
    let msg = error_of_body(
        "<bsdf type=\"roughdielectric\" id=\"r\"><string name=\"int_ior\" value=\"unobtainium\"/></bsdf>",
    );
    assert!(msg.contains("<bsdf type=\"roughdielectric\">: unknown medium `unobtainium` (known: vacuum"), "{msg}");
    // The transmittance takes no texture (wavetrace's glass tint is one colour).
    let msg = error_of_body("<bsdf type=\"roughdielectric\" id=\"r\"><texture type=\"checkerboard\" name=\"specular_transmittance\"/></bsdf>");
    assert!(msg.contains("<texture> inside <bsdf type=\"roughdielectric\">: not supported here"), "{msg}");
}

#[test]
fn textures_nested_or_referenced_become_colours() {
    let f = Files::temp();
    f.write("tex/wood.png", "not decoded by the importer");
    f.write("inc/wood.png", "another one");
    // An include in another folder names its bitmap relative to itself, as meshes are.
    f.write(
        "inc/decls.xml",
        "<scene version=\"3.0.0\"><texture type=\"bitmap\" id=\"far\"><string name=\"filename\" value=\"wood.png\"/></texture></scene>",
    );
    let body = "<bsdf type=\"diffuse\" id=\"wood\"><texture type=\"bitmap\" name=\"reflectance\">\
                <string name=\"filename\" value=\"tex/wood.png\"/><boolean name=\"raw\" value=\"true\"/>\
                <string name=\"filter_type\" value=\"nearest\"/><string name=\"wrap_mode\" value=\"mirror\"/>\
                <transform name=\"to_uv\"><scale x=\"4\" y=\"2\"/><translate x=\"0.5\"/></transform></texture></bsdf>\n\
                <bsdf type=\"diffuse\" id=\"checks\"><ref name=\"reflectance\" id=\"board\"/></bsdf>\n\
                <bsdf type=\"diffuse\" id=\"far\"><ref name=\"reflectance\" id=\"far\"/></bsdf>\n\
                <texture type=\"checkerboard\" id=\"board\"><rgb name=\"color0\" value=\"1, 0, 0\"/><float name=\"color1\" value=\"0.1\"/></texture>\n\
                <include filename=\"inc/decls.xml\"/>";
    // Ids are one namespace: the bitmap "far" needs another id than the BSDF "far".
    let body = body.replace("id=\"far\"><ref", "id=\"far-bsdf\"><ref");
    let s = imported(&f.write("s.xml", xml_scene(&body)));
    let abs = |p: &str| std::fs::canonicalize(f.dir().join(p)).expect("canonical").display().to_string();
    let diffuse =
        |color: ColorDesc| json(MaterialDesc::Diffuse { color, specular: [0.0; 3], shininess: 0.0, two_sided: false });
    let wood = TextureDesc::Bitmap {
        file: abs("tex/wood.png"),
        raw: true,
        wrap: Some("mirror".into()),
        filter: Some("nearest".into()),
        to_uv: Some(vec![TransformOp::Scale([4.0, 2.0, 1.0]), TransformOp::Translate([0.5, 0.0, 0.0])]),
    };
    assert_eq!(material(&s, "wood"), diffuse(ColorDesc::Texture(wood)));
    let board = TextureDesc::Checkerboard { color0: [1.0, 0.0, 0.0], color1: [0.1; 3], to_uv: None };
    assert_eq!(material(&s, "checks"), diffuse(ColorDesc::Texture(board)));
    let far = TextureDesc::Bitmap { file: abs("inc/wood.png"), raw: false, wrap: None, filter: None, to_uv: None };
    assert_eq!(material(&s, "far-bsdf"), diffuse(ColorDesc::Texture(far)));
}

#[test]
fn bad_values_are_refused_where_mitsuba_refuses_them() {
    let f = Files::temp();
    f.write("t.png", "png");
    let rough = |inner: &str| format!("<bsdf type=\"roughconductor\" id=\"r\">{inner}</bsdf>");
    let cases = [
        // Mitsuba's microfacet names: beckmann and ggx (it reads them case-insensitively).
        (rough("<string name=\"distribution\" value=\"phong\"/>"), "s.xml:7:36: <bsdf type=\"roughconductor\">: distribution `phong` is not beckmann or ggx"),
        (rough("<float name=\"alpha\" value=\"0.1\"/><float name=\"alpha_u\" value=\"0.1\"/><float name=\"alpha_v\" value=\"0.1\"/>"), "s.xml:7:36: <bsdf type=\"roughconductor\">: give `alpha` or `alpha_u` and `alpha_v`, not both"),
        (rough("<float name=\"alpha_u\" value=\"0.1\"/>"), "s.xml:7:1: <bsdf type=\"roughconductor\">: give both `alpha_u` and `alpha_v`"),
        (rough("<ref name=\"alpha\" id=\"x\"/>"), "<ref name=\"alpha\"> inside <bsdf type=\"roughconductor\">: not supported; wavetrace takes a texture (bitmap, checkerboard"),
        (rough("<string name=\"material\" value=\"Au\"/><rgb name=\"eta\" value=\"1\"/>"), "s.xml:7:72: <bsdf type=\"roughconductor\">: material `Au` with `eta`/`k`: give a named material or eta and k, not both"),
        ("<bsdf type=\"diffuse\" id=\"d\"><ref id=\"x\"/></bsdf>".to_string(), "<ref> inside <bsdf type=\"diffuse\">: not supported; wavetrace takes a texture (bitmap, checkerboard (as a diffuse `reflectance`, a plastic's `diffuse_reflectance` or a conductor's `specular_reflectance`)) for reflectance only"),
        ("<bsdf type=\"diffuse\" id=\"d\"><rgb name=\"reflectance\" value=\"1\"/><texture type=\"checkerboard\" name=\"reflectance\"/></bsdf>".to_string(), "<bsdf type=\"diffuse\">: parameter `reflectance` given twice"),
        ("<texture type=\"bitmap\" id=\"t\"><string name=\"filename\" value=\"t.png\"/><string name=\"wrap_mode\" value=\"Clamp\"/></texture>".to_string(), "<texture type=\"bitmap\">: wrap_mode `Clamp` is not one of repeat, mirror, clamp"),
        ("<texture type=\"bitmap\" id=\"t\"><string name=\"filename\" value=\"t.png\"/><string name=\"filter_type\" value=\"cubic\"/></texture>".to_string(), "<texture type=\"bitmap\">: filter_type `cubic` is not one of bilinear, nearest"),
        ("<texture type=\"bitmap\" id=\"t\"><string name=\"filename\" value=\"missing.png\"/></texture>".to_string(), "file `missing.png` not found"),
        ("<texture type=\"bitmap\" id=\"t\"/>".to_string(), "s.xml:7:1: <texture type=\"bitmap\">: lacks `filename`"),
        ("<texture type=\"mesh_attribute\" id=\"t\"/>".to_string(), "s.xml:7:1: <texture type=\"mesh_attribute\">: not supported; wavetrace imports texture types bitmap, checkerboard"),
        ("<texture type=\"checkerboard\" id=\"t\"><texture type=\"checkerboard\" name=\"color0\"/></texture>".to_string(), "<texture> inside <texture type=\"checkerboard\">: not supported here"),
    ];
    for (body, needle) in cases {
        let msg = import_error(&f.write("s.xml", xml_scene(&body)));
        assert!(msg.contains(needle), "`{needle}` not in: {msg}");
    }
    // Numbers pass as written: the loader checks a roughness's range, and its message
    // points back at the BSDF element (`places`).
    let s = scene_of(&rough("<float name=\"alpha\" value=\"-0.2\"/>"));
    assert_eq!(material(&s, "r")["alpha"], serde_json::json!(-0.2f32));
    assert!(s.places.iter().any(|(p, l)| p == "materials.r" && l.line == 7), "{:?}", s.places);
}

#[test]
fn a_rectangle_quad_has_mitsubas_uv() {
    // corner + a·u + b·v with corner (-1, -1), u = (2, 0), v = (0, 2) is the local point
    // (2a - 1, 2b - 1): (a, b) = ((x + 1) / 2, (y + 1) / 2), Mitsuba's rectangle UV.
    let s = scene_of("<shape type=\"rectangle\"/>");
    match &s.file.objects[..] {
        [ObjectDesc::Quad { corner, edge_u, edge_v, .. }] => {
            assert_eq!((*corner, *edge_u, *edge_v), ([-1.0, -1.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]))
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn thin_dielectrics_are_thin_smooth_glass() {
    let s = scene_of("<bsdf type=\"thindielectric\" id=\"pane\"><rgb name=\"specular_transmittance\" value=\"0.9, 0.9, 0.8\"/></bsdf>");
    let pane = json(MaterialDesc::Dielectric {
        ior: 1.5046 / 1.00028,
        reflect_ratio: None,
        color: [0.9, 0.9, 0.8],
        thin: true,
        distribution: None,
        alpha: None,
        alpha_u: None,
        alpha_v: None,
    });
    assert_eq!(material(&s, "pane"), pane);
}
