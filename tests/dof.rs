//! Depth of field: a closed aperture is the pinhole path, and the focus plane stays sharp.

mod support;

use support::toml::{render_block, wall};
use support::*;

/// An emitter facing the camera covering the left half of the view, 5 units away.
fn edge() -> String {
    render_block(&["width=32", "height=32", "aa.samples=16"]) + &wall(5.0, &["fov_y=30.0"])
}

#[test]
fn closed_aperture_is_the_pinhole_path() {
    let pinhole = render_text(&edge(), &[], 2);
    let closed = render_text(&edge(), &["camera.aperture=0", "render.dof.samples=8"], 2);
    assert_eq!(pinhole.image, closed.image);
    assert_eq!(pinhole.stats.camera_rays, closed.stats.camera_rays, "no lens samples at aperture 0");
    assert_eq!(closed.stats.camera_rays, 32 * 32 * 16);
}

#[test]
fn focus_plane_stays_sharp_and_other_depths_blur() {
    let pinhole = render_text(&edge(), &[], 2);
    let in_focus = render_text(&edge(), &["camera.aperture=0.5", "render.dof.samples=8"], 2);
    let out_of_focus =
        render_text(&edge(), &["camera.aperture=0.5", "render.dof.samples=8", "camera.focus_distance=2.5"], 2);
    let sharp = rmse(&pinhole.image, &in_focus.image);
    let blurred = rmse(&pinhole.image, &out_of_focus.image);
    assert!(sharp < 0.01, "edge on the focus plane blurred: RMSE {sharp}");
    assert!(blurred > 0.05, "edge off the focus plane stayed sharp: RMSE {blurred}");
    assert_eq!(in_focus.stats.camera_rays, 32 * 32 * 16 * 8);
}
