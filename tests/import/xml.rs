//! The XML reader and the plugin mapping: what loads, and every refusal naming the file,
//! line, column, the plugin and the supported list.

use glam::Vec3;
use wavetrace::accel::Shape;
use wavetrace::scene::{Color, Light, Material, Transport};

use crate::{error_of, load_file, try_load, xml_scene, Files};

#[test]
fn unsupported_plugins_name_the_place_and_the_supported_list() {
    let f = Files::temp();
    let cases = [
        ("<bsdf type=\"principled\" id=\"a\"/>", "<bsdf type=\"principled\">: not supported; wavetrace imports bsdf types diffuse, twosided"),
        ("<shape type=\"disk\"/>", "<shape type=\"disk\">: not supported; wavetrace imports shape types obj, ply, rectangle"),
        ("<emitter type=\"spot\"/>", "<emitter type=\"spot\">: not supported; wavetrace imports emitter types area"),
        ("<emitter type=\"envmap\"/>", "<emitter type=\"envmap\">: lacks `filename`"),
        (
            "<emitter type=\"constant\"/><emitter type=\"constant\"/>",
            "a second environment",
        ),
        ("<texture type=\"bitmap\"/>", "<texture type=\"bitmap\">: a texture at the top level needs an id"),
        (
            "<shape type=\"sphere\"><bsdf type=\"diffuse\"><texture type=\"wood\" name=\"reflectance\"/></bsdf></shape>",
            "<texture type=\"wood\">: not supported; wavetrace imports texture types bitmap, checkerboard",
        ),
        (
            "<shape type=\"sphere\"><bsdf type=\"diffuse\"><spectrum name=\"reflectance\" value=\"400:0.1, 700:0.5\"/></bsdf></shape>",
            "wavelength:value lists",
        ),
        (
            "<shape type=\"sphere\"><bsdf type=\"roughconductor\"><texture type=\"checkerboard\" name=\"alpha\"/></bsdf></shape>",
            "<texture name=\"alpha\"> inside <bsdf type=\"roughconductor\">: not supported; wavetrace takes a texture",
        ),
        ("<shape type=\"sphere\"><float name=\"radius\" value=\"1\"/><float name=\"weird\" value=\"1\"/></shape>", "parameter `weird` is not supported (supported: center, radius"),
        (
            "<shape type=\"sphere\"><transform name=\"to_world\"><scale x=\"2\"/></transform></shape>",
            "to_world must be a uniform scale",
        ),
        (
            "<shape type=\"sphere\"><boolean name=\"flip_normals\" value=\"true\"/></shape>",
            "flip_normals is not supported",
        ),
    ];
    for (body, needle) in cases {
        let path = f.write("s.xml", xml_scene(body));
        let msg = error_of(&path, &[]);
        // The body starts on line 7 of xml_scene's text.
        assert!(msg.contains("s.xml:7:") || msg.contains("s.xml:8:"), "no line in: {msg}\n{body}");
        assert!(msg.contains(needle), "`{needle}` not in: {msg}");
    }
}

#[test]
fn malformed_and_hostile_xml_is_refused_with_a_position() {
    let f = Files::temp();
    let path = f.write("a.xml", "<scene version=\"3.0.0\">\n  <shape type=\"obj\">\n</scene>\n");
    let msg = error_of(&path, &[]);
    assert!(msg.starts_with(&format!("{}:3:", path.display())) && msg.contains("malformed XML"), "{msg}");
    // Entity definitions (the billion-laughs expansion) never get that far.
    let lol = "<?xml version=\"1.0\"?>\n<!DOCTYPE scene [<!ENTITY a \"aaaaaaaaaa\"><!ENTITY b \"&a;&a;&a;&a;&a;&a;&a;&a;\">]>\n<scene version=\"3.0.0\">&b;</scene>\n";
    let msg = error_of(&f.write("lol.xml", lol), &[]);
    assert!(msg.contains("DOCTYPE"), "{msg}");
    let deep = format!("<scene version=\"3.0.0\">{}{}</scene>", "<shape>".repeat(200), "</shape>".repeat(200));
    let msg = error_of(&f.write("deep.xml", deep), &[]);
    assert!(msg.contains("nest deeper than 64"), "{msg}");
    let old = "<scene version=\"0.6.0\">\n<shape type=\"obj\"/></scene>";
    let msg = error_of(&f.write("old.xml", old), &[]);
    assert!(msg.contains(":1:1: scene version 0.6.0") && msg.contains("upgrades"), "{msg}");
    let msg = error_of(&f.write("nov.xml", "<scene><shape/></scene>"), &[]);
    assert!(msg.contains("lacks the `version` attribute"), "{msg}");
    let msg = error_of(&f.write("nosensor.xml", "<scene version=\"2.1.0\"/>"), &[]);
    assert!(msg.contains("no <sensor>"), "{msg}");
}

#[test]
fn includes_resolve_relative_and_cycles_are_refused() {
    let f = Files::temp();
    f.write("inc/bsdfs.xml", "<scene version=\"3.0.0\"><bsdf type=\"diffuse\" id=\"red\"><rgb name=\"reflectance\" value=\"0.5, 0, 0\"/></bsdf></scene>");
    let body = "<include filename=\"inc/bsdfs.xml\"/>\n<shape type=\"sphere\"><ref id=\"red\"/></shape>";
    let scene = load_file(&f.write("main.xml", xml_scene(body)));
    assert_eq!(
        scene.materials,
        vec![Material::Diffuse {
            color: Color::Rgb(Vec3::new(0.5, 0.0, 0.0)),
            specular: Vec3::ZERO,
            shininess: 0.0,
            two_sided: false
        }]
    );
    f.write("loop1.xml", "<scene version=\"3.0.0\"><include filename=\"loop2.xml\"/></scene>");
    f.write("loop2.xml", "<scene version=\"3.0.0\"><include filename=\"loop1.xml\"/></scene>");
    let msg = error_of(&f.write("c.xml", xml_scene("<include filename=\"loop1.xml\"/>")), &[]);
    assert!(msg.contains("includes itself"), "{msg}");
    let msg = error_of(&f.write("m.xml", xml_scene("<include filename=\"missing.xml\"/>")), &[]);
    assert!(msg.contains("m.xml:7:1: file `missing.xml` not found"), "{msg}");
    let msg = error_of(&f.write("r.xml", xml_scene("<shape type=\"sphere\"><ref id=\"nope\"/></shape>")), &[]);
    assert!(msg.contains("r.xml:7:22: <ref id=\"nope\">: no element has id \"nope\""), "{msg}");
}

#[test]
fn defaults_are_substituted_and_dash_d_wins() {
    let f = Files::temp();
    let text = xml_scene(
        "<default name=\"r\" value=\"0.25\"/>\n<shape type=\"sphere\"><float name=\"radius\" value=\"$r\"/></shape>",
    );
    let path = f.write("d.xml", text);
    let radius = |s: &wavetrace::Scene| match s.accel.prim(0).shape {
        Shape::Sphere { radius, .. } => radius,
        _ => panic!("not a sphere"),
    };
    assert_eq!(radius(&load_file(&path)), 0.25);
    assert_eq!(radius(&try_load(&path, &[("r", "2")], &[]).unwrap()), 2.0);
    // --set applies to the imported scene by wavetrace's own paths.
    assert_eq!(radius(&try_load(&path, &[], &["objects.0.radius=3"]).unwrap()), 3.0);
    let msg = error_of(
        &f.write("u.xml", xml_scene("<shape type=\"sphere\"><float name=\"radius\" value=\"$nope\"/></shape>")),
        &[],
    );
    assert!(msg.contains("`$nope` has no value"), "{msg}");
    // Later validation of a converted value points back at its element.
    let msg = error_of(&path, &[("r", "-1")]);
    assert!(msg.contains("d.xml:8:1: field `objects.0.radius`: -1 must be > 0"), "{msg}");
}

#[test]
fn bsdfs_map_to_materials() {
    let f = Files::temp();
    let body = "<shape type=\"sphere\"><bsdf type=\"dielectric\"><string name=\"int_ior\" value=\"water\"/><float name=\"ext_ior\" value=\"1\"/><rgb name=\"specular_transmittance\" value=\"0.9, 0.8, 0.7\"/></bsdf></shape>\n\
                <shape type=\"sphere\"><point name=\"center\" x=\"3\"/><bsdf type=\"conductor\"><float name=\"specular_reflectance\" value=\"0.5\"/></bsdf></shape>\n\
                <shape type=\"sphere\"><point name=\"center\" x=\"-3\"/></shape>";
    let scene = load_file(&f.write("b.xml", xml_scene(body)));
    let mats = &scene.materials;
    assert!(mats.iter().any(|m| matches!(m, Material::Dielectric { ior, tint, .. } if *ior == 1.333 && *tint == Vec3::new(0.9, 0.8, 0.7))), "{mats:?}");
    assert!(mats.contains(&Material::Mirror { color: Vec3::splat(0.5) }), "{mats:?}");
    // No BSDF: Mitsuba's default, a one-sided diffuse of reflectance 0.5.
    assert!(mats.contains(&Material::Diffuse {
        color: Color::Rgb(Vec3::splat(0.5)),
        specular: Vec3::ZERO,
        shininess: 0.0,
        two_sided: false
    }));
}

#[test]
fn cube_is_six_outward_faces_and_instances_are_flattened() {
    let f = Files::temp();
    let body = "<shape type=\"cube\"><transform name=\"to_world\"><scale value=\"0.5\"/><translate x=\"1\"/></transform></shape>\n\
        <shape type=\"shapegroup\" id=\"g\"><shape type=\"sphere\"><float name=\"radius\" value=\"0.1\"/></shape></shape>\n\
        <shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\"><translate y=\"2\"/></transform></shape>\n\
        <shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\"><scale value=\"2\"/><translate y=\"-2\"/></transform></shape>";
    let scene = load_file(&f.write("c.xml", xml_scene(body)));
    let mut quads = 0;
    let mut spheres = Vec::new();
    for p in scene.accel.prims() {
        match p.shape {
            Shape::Quad { corner, u, v } => {
                quads += 1;
                let centre = corner + 0.5 * (u + v);
                // Outward: the normal points away from the cube's centre (1, 0, 0).
                assert!(u.cross(v).dot(centre - Vec3::X) > 0.0, "inward face at {centre}");
                assert_eq!(u.length(), 1.0);
            }
            Shape::Sphere { center, radius } => spheres.push((center.y, radius)),
            _ => panic!("unexpected shape"),
        }
    }
    spheres.sort_by(|a, b| a.0.total_cmp(&b.0));
    assert_eq!(quads, 6);
    assert_eq!(spheres, vec![(-2.0, 0.2), (2.0, 0.1)]);
}

#[test]
fn emitters_rectangle_point_constant_sphere_and_directional() {
    let f = Files::temp();
    // A mirroring to_world keeps Mitsuba's normal (+z through the inverse transpose):
    // the edges swap so the light still emits towards +z.
    let body = "<shape type=\"rectangle\"><transform name=\"to_world\"><scale x=\"-1\"/></transform><emitter type=\"area\"><rgb name=\"radiance\" value=\"1, 2, 3\"/></emitter></shape>\n\
        <shape type=\"rectangle\"><boolean name=\"flip_normals\" value=\"true\"/><emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>\n\
        <emitter type=\"point\"><transform name=\"to_world\"><translate x=\"1\" y=\"2\" z=\"3\"/></transform><float name=\"intensity\" value=\"5\"/></emitter>\n\
        <emitter type=\"constant\"><rgb name=\"radiance\" value=\"0.1, 0.2, 0.3\"/></emitter>\n\
        <shape type=\"sphere\"><float name=\"radius\" value=\"0.5\"/><transform name=\"to_world\"><scale value=\"2\"/><translate x=\"1\"/></transform><emitter type=\"area\"><rgb name=\"radiance\" value=\"7\"/></emitter></shape>\n\
        <emitter type=\"directional\"><transform name=\"to_world\"><rotate x=\"1\" angle=\"90\"/></transform><rgb name=\"irradiance\" value=\"2\"/></emitter>";
    let scene = load_file(&f.write("e.xml", xml_scene(body)));
    match scene.lights[..] {
        [Light::Quad { normal: n0, radiance, area, .. }, Light::Quad { normal: n1, .. }, Light::Point { position, intensity }, Light::Sphere { center, radius, radiance: r }, Light::Directional { direction, irradiance }] =>
        {
            assert_eq!((n0, radiance, area), (Vec3::Z, Vec3::new(1.0, 2.0, 3.0), 4.0));
            assert_eq!(n1, Vec3::NEG_Z);
            assert_eq!((position, intensity), (Vec3::new(1.0, 2.0, 3.0), Vec3::splat(5.0)));
            assert_eq!((center, radius, r), (Vec3::X, 1.0, Vec3::splat(7.0)));
            // Mitsuba's local +z turned 90° about x: −y.
            assert!((direction - Vec3::NEG_Y).length() < 1e-6 && irradiance == Vec3::splat(2.0), "{direction}");
        }
        _ => panic!("{:?}", scene.lights),
    }
    assert_eq!(scene.background.eval(Vec3::Y), Vec3::new(0.1, 0.2, 0.3));
}

#[test]
fn a_cornell_box_written_as_mitsuba_writes_one_loads() {
    // The constructs of Mitsuba's own tutorial Cornell box: `$integrator` as a plugin
    // type, a perspective sensor with a (meaningless) focus_distance and clip planes, a
    // tent filter and sample_border on the film, one-sided diffuse BSDFs by id, OBJ walls,
    // an OBJ luminaire that carries a BSDF reference next to its emitter.
    let f = Files::temp();
    f.write("meshes/floor.obj", "v -1 -1 1\nv 1 -1 1\nv 1 -1 -1\nv -1 -1 -1\nf 1 2 3 4\n");
    f.write("meshes/lamp.obj", "v 0.25 1 -0.25\nv 0.25 1 0.25\nv -0.25 1 0.25\nv -0.25 1 -0.25\nf 1 2 3 4\n");
    let text = r#"<scene version="3.0.0">
    <default name="integrator" value="path"/>
    <default name="res" value="8"/>
    <integrator type='$integrator'><integer name="max_depth" value="6"/></integrator>
    <sensor type="perspective" id="sensor">
        <string name="fov_axis" value="smaller"/>
        <float name="near_clip" value="0.001"/>
        <float name="far_clip" value="100.0"/>
        <float name="focus_distance" value="1000"/>
        <float name="fov" value="39.3077"/>
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="$res"/><integer name="height" value="$res"/>
            <rfilter type="tent"/>
            <string name="pixel_format" value="rgb"/>
            <boolean name="sample_border" value="true"/>
        </film>
    </sensor>
    <bsdf type="diffuse" id="white"><rgb name="reflectance" value="0.885809, 0.698859, 0.666422"/></bsdf>
    <bsdf type="dielectric" id="glass"/>
    <shape type="obj" id="light">
        <string name="filename" value="meshes/lamp.obj"/>
        <transform name="to_world"><translate y="-0.01"/></transform>
        <ref id="white"/>
        <emitter type="area"><rgb name="radiance" value="18.387, 13.9873, 6.75357"/></emitter>
    </shape>
    <shape type="obj" id="floor"><string name="filename" value="meshes/floor.obj"/><ref id="white"/></shape>
    <shape type="sphere" id="glasssphere">
        <transform name="to_world"><scale value="0.25"/><translate x="0.5" y="-0.75" z="-0.2"/></transform>
        <ref id="glass"/>
    </shape>
</scene>"#;
    let scene = load_file(&f.write("cbox.xml", text));
    // Two triangle lights facing down at y = 0.99, the glass ior bk7 / air.
    assert_eq!(scene.lights.len(), 2);
    assert!(scene
        .lights
        .iter()
        .all(|l| matches!(l, Light::Triangle { normal, v0, .. } if *normal == Vec3::NEG_Y && v0.y == 0.99)));
    assert!(scene
        .materials
        .iter()
        .any(|m| matches!(m, Material::Dielectric { ior, .. } if (*ior - 1.5046 / 1.00028).abs() < 1e-6)));
    assert_eq!(scene.settings.max_depth, 5);
    // Mitsuba's `path`, with its default Russian roulette and one light sample per hit.
    assert_eq!(scene.settings.transport, Transport::Path { rr_depth: 5, hide_emitters: false });
    assert_eq!(scene.settings.shadow_samples, 1);
    let notes = scene.info.notes.join("\n");
    assert!(notes.contains("box filter"), "`box filter` not in the notes:\n{notes}");
}

#[test]
fn a_duplicate_id_is_refused_naming_both_places() {
    let f = Files::temp();
    f.write("inc.xml", "<scene version=\"3.0.0\">\n<bsdf type=\"diffuse\" id=\"wall\"/>\n</scene>\n");
    let body = "<bsdf type=\"diffuse\" id=\"wall\"/>\n<include filename=\"inc.xml\"/>";
    let msg = error_of(&f.write("dup.xml", xml_scene(body)), &[]);
    // Line 7 of dup.xml first, then line 2 of inc.xml: both places, file:line:col each.
    assert!(msg.contains("inc.xml:2:1: <bsdf> has duplicate id \"wall\""), "{msg}");
    assert!(msg.contains("first given at") && msg.contains("dup.xml:7:1"), "{msg}");
    // The same id on a shape and a BSDF is a clash too: ids are one namespace.
    let body = "<bsdf type=\"diffuse\" id=\"a\"/>\n<shape type=\"sphere\" id=\"a\"/>";
    let msg = error_of(&f.write("dup2.xml", xml_scene(body)), &[]);
    assert!(msg.contains("dup2.xml:8:1") && msg.contains("dup2.xml:7:1") && msg.contains("duplicate id"), "{msg}");
    // References by id are not definitions.
    let body = "<bsdf type=\"diffuse\" id=\"b\"/>\n<shape type=\"sphere\"><ref id=\"b\"/></shape>\n\
                <shape type=\"sphere\"><ref id=\"b\"/></shape>";
    load_file(&f.write("refs.xml", xml_scene(body)));
}

#[test]
fn a_dash_d_no_parameter_uses_is_refused_naming_the_parameters() {
    let f = Files::temp();
    let text = xml_scene(
        "<default name=\"spp\" value=\"4\"/>\n<default name=\"unused\" value=\"1\"/>\n\
         <shape type=\"sphere\"><float name=\"radius\" value=\"$r\"/></shape>",
    );
    let path = f.write("p.xml", text);
    let msg = error_of(&path, &[("r", "1"), ("sp", "4")]);
    assert!(msg.contains("p.xml") && msg.contains("-D `sp=4`: the scene uses no `$sp`"), "{msg}");
    assert!(msg.contains("its parameters: r, spp, unused"), "{msg}");
    // A -D whose name a <default> declares but no `$` uses is unused as well.
    let msg = error_of(&path, &[("r", "1"), ("spp", "8")]);
    assert!(msg.contains("-D `spp=8`"), "{msg}");
    // Used ones load.
    try_load(&path, &[("r", "1")], &[]).unwrap();
}

#[test]
fn every_unsupported_element_is_reported_in_one_run() {
    let f = Files::temp();
    let body = "<shape type=\"disk\"/>\n<emitter type=\"envmap\"/>\n<texture type=\"bitmap\"/>\n\
                <bsdf type=\"principled\" id=\"rp\"/>\n<shape type=\"cylinder\"><ref id=\"rp\"/></shape>\n\
                <shape type=\"sphere\"><ref id=\"rp\"/></shape>";
    let msg = error_of(&f.write("five.xml", xml_scene(body)), &[]);
    assert!(msg.starts_with("5 problems in the scene:"), "{msg}");
    for needle in [
        "five.xml:7:1: <shape type=\"disk\">",
        "five.xml:8:1: <emitter type=\"envmap\">",
        "five.xml:9:1: <texture type=\"bitmap\">",
        "five.xml:10:1: <bsdf type=\"principled\">",
        "five.xml:11:1: <shape type=\"cylinder\">",
    ] {
        assert!(msg.contains(needle), "`{needle}` not in: {msg}");
    }
    // The sphere's reference to the failed BSDF adds no second, misleading error.
    assert!(!msg.contains("no element has id"), "{msg}");
    // Many: the first 20, then a count.
    let many: String = (0..25).map(|_| "<shape type=\"disk\"/>\n").collect();
    let msg = error_of(&f.write("many.xml", xml_scene(&many)), &[]);
    assert!(msg.starts_with("25 problems"), "{msg}");
    assert_eq!(msg.matches("<shape type=\"disk\">").count(), 20, "{msg}");
    assert!(msg.ends_with("and 5 more"), "{msg}");
}

#[test]
fn integrators_map_to_transports_and_others_are_refused() {
    let f = Files::temp();
    let load = |name: &str, integrator: &str| load_file(&f.write(name, xml_scene(integrator)));
    // No <integrator>: Mitsuba's default, `path` with unbounded depth.
    let none = load("none.xml", "");
    assert_eq!(none.settings.transport, Transport::Path { rr_depth: 5, hide_emitters: false });
    assert_eq!(none.settings.max_depth, wavetrace::scene::values::MAX_DEPTH);
    let path = load(
        "path.xml",
        "<integrator type=\"path\"><integer name=\"max_depth\" value=\"3\"/><integer name=\"rr_depth\" value=\"2\"/>\
         <boolean name=\"hide_emitters\" value=\"true\"/></integrator>",
    );
    assert_eq!(path.settings.transport, Transport::Path { rr_depth: 2, hide_emitters: true });
    assert_eq!((path.settings.max_depth, path.settings.shadow_samples), (2, 1));
    let direct = load("direct.xml", "<integrator type=\"direct\"/>");
    assert_eq!(direct.settings.max_depth, 1);
    assert!(matches!(direct.settings.transport, Transport::Path { rr_depth: u32::MAX, .. }));
    for (body, needle) in [
        ("<integrator type=\"volpath\"/>", "wavetrace imports integrator types path, direct and whitted"),
        ("<integrator type=\"path\"><integer name=\"max_depth\" value=\"0\"/></integrator>", "max_depth 0"),
        (
            "<integrator type=\"path\"><integer name=\"samples\" value=\"2\"/></integrator>",
            "`samples` is not supported",
        ),
        ("<integrator type=\"direct\"><integer name=\"emitter_samples\" value=\"4\"/></integrator>", "emitter_samples"),
    ] {
        let msg = error_of(&f.write("bad.xml", xml_scene(body)), &[]);
        assert!(msg.contains(needle) && msg.contains("bad.xml:"), "`{needle}` not in {msg}");
    }
}
