//! Motion blur in a scene description: the shutter, and where the camera and each
//! object are over it. Something with `transform_end` moves from `transform` (time 0)
//! to `transform_end` (time 1), unless the shutter has zero length or the two are
//! equal: then it is placed, still, where it is at the shutter's time, and the scene
//! renders as a static one (at time 0, bit for bit the scene without `transform_end`).

use crate::motion::Motion;
use crate::scene::format::{CameraDesc, ObjectDesc, TransformOp};
use crate::scene::transform::{look_at, Transform};
use crate::scene::values::{in_range, transform, Ctx};
use crate::scene::{Camera, CameraMotion};
use crate::Result;
use glam::{DAffine3, DMat4};

/// Why a light cannot take `transform_end`.
pub(super) const LIGHTS_STILL: &str =
    "lights stay still under motion blur: `transform_end` moves objects and the camera only";

/// Where an object goes.
pub(super) enum Placed {
    /// Still, as described.
    AsIs,
    /// Still, with this description (its `transform` the one it is placed with).
    Still(ObjectDesc),
    /// Moving by this motion; the description's primitives are in object space (no
    /// `transform`).
    Moving(Box<Motion>, ObjectDesc),
}

/// `camera.shutter`, checked: open ≤ close, both in [0, 1].
pub(super) fn shutter(c: &CameraDesc, ctx: &Ctx) -> Result<[f32; 2]> {
    let [open, close] = c.shutter;
    if !(0.0..=1.0).contains(&open) || !(0.0..=1.0).contains(&close) {
        return Err(ctx.fail("camera.shutter", format!("[{open}, {close}]: both times must be in [0, 1]")));
    }
    if open > close {
        return Err(ctx.fail("camera.shutter", format!("[{open}, {close}] is reversed: it opens after it closes")));
    }
    Ok(c.shutter)
}

/// One bound for where `transform` and `transform_end` move things: a still object's
/// `transform` is refused when its shape lands beyond ±MAX_COORD, and a moving object
/// is built in its own space, so both ends of its motion are held to the same bound
/// here, by their translation (a `transform_end` of 1e30 used to pass).
fn check_translation(ctx: &Ctx, field: &str, m: DMat4, time: u32) -> Result<()> {
    let t = m.w_axis.truncate().as_vec3();
    if !super::in_range(t) {
        return Err(
            ctx.fail(field, format!("translates by {t} at time {time}: beyond ±{:e} scene units", super::MAX_COORD))
        );
    }
    Ok(())
}

/// The matrix of an affine transform as a `matrix` step (row by row).
fn matrix_op(m: DAffine3) -> TransformOp {
    let m = DMat4::from(m).transpose().to_cols_array();
    TransformOp::Matrix(m.iter().map(|&x| x as f32).collect())
}

/// A copy of `o` with `transform` replaced and no `transform_end`.
fn with_transform(o: &ObjectDesc, ops: Option<Vec<TransformOp>>) -> ObjectDesc {
    let mut o = o.clone();
    match &mut o {
        ObjectDesc::Sphere { transform, transform_end, .. }
        | ObjectDesc::Quad { transform, transform_end, .. }
        | ObjectDesc::Mesh { transform, transform_end, .. } => {
            *transform = ops;
            *transform_end = None;
        }
    }
    o
}

/// The motion from `start` (identity when absent) to `end`, its errors at `path`'s
/// `transform_end`, checked invertible over `shutter`.
fn motion(
    ctx: &Ctx,
    path: &str,
    start: &Option<Vec<TransformOp>>,
    end: &[TransformOp],
    shutter: [f32; 2],
) -> Result<Motion> {
    let field = format!("{path}.transform_end");
    let t0 = match start {
        Some(ops) => transform(ctx, &format!("{path}.transform"), ops)?,
        None => Transform::IDENTITY,
    };
    let t1 = transform(ctx, &field, end)?;
    check_translation(ctx, &format!("{path}.transform"), t0.m, 0)?;
    check_translation(ctx, &field, t1.m, 1)?;
    let m = Motion::new(t0.m, t1.m).map_err(|e| ctx.fail(&field, e))?;
    m.check_invertible(shutter).map_err(|e| ctx.fail(&field, e))?;
    Ok(m)
}

/// Where object `o` goes: still (as described, or at the shutter's time when it has
/// `transform_end` but does not move over the shutter), or moving.
pub(super) fn object(ctx: &Ctx, path: &str, o: &ObjectDesc, shutter: [f32; 2]) -> Result<Placed> {
    let (start, end) = match o {
        ObjectDesc::Sphere { transform, transform_end, .. }
        | ObjectDesc::Quad { transform, transform_end, .. }
        | ObjectDesc::Mesh { transform, transform_end, .. } => (transform, transform_end),
    };
    let Some(end) = end else { return Ok(Placed::AsIs) };
    let field = format!("{path}.transform_end");
    if let ObjectDesc::Mesh { emission: Some(_), .. } = o {
        return Err(ctx.fail(&field, format!("a mesh with `emission` is a light: {LIGHTS_STILL}")));
    }
    let m = motion(ctx, path, start, end, shutter)?;
    if let ObjectDesc::Sphere { .. } = o {
        // Both ends: a moving sphere is built without its `transform`, whose own check
        // then never runs.
        let s = |ops: &[TransformOp]| Transform::from_ops(ops).ok().and_then(|t| t.uniform_scale());
        let bad = [(start.as_deref(), format!("{path}.transform")), (Some(&end[..]), field.clone())]
            .into_iter()
            .find(|(ops, _)| ops.is_some_and(|ops| s(ops).is_none()));
        if let Some((_, at)) = bad {
            return Err(ctx.fail(&at, "a sphere takes only a uniform scale (with rotations and translations)"));
        }
    }
    if shutter[0] == shutter[1] || m.is_static() {
        let time = shutter[0];
        let ops = if time == 0.0 || m.is_static() {
            start.clone()
        } else if time == 1.0 {
            Some(end.clone())
        } else {
            Some(vec![matrix_op(m.at(time))])
        };
        return Ok(Placed::Still(with_transform(o, ops)));
    }
    Ok(Placed::Moving(Box::new(m), with_transform(o, None)))
}

/// The camera's motion, when it has `transform_end` and the shutter is open; with a
/// zero-length shutter the camera is moved to where it is at the shutter's time.
pub(super) fn camera(c: &CameraDesc, camera: &mut Camera, shutter: [f32; 2], ctx: &Ctx) -> Result<()> {
    let Some(end) = &c.transform_end else { return Ok(()) };
    let start = match (&c.transform, c.position, c.look_at) {
        (Some(ops), _, _) => transform(ctx, "camera.transform", ops)?.m,
        (None, Some(p), Some(l)) => {
            look_at(glam::Vec3::from(p).as_dvec3(), glam::Vec3::from(l).as_dvec3(), glam::Vec3::from(c.up).as_dvec3())
                .map_err(|e| ctx.fail("camera.look_at", e))?
        }
        _ => return Ok(()), // the camera's own checks have refused it already
    };
    let end = transform(ctx, "camera.transform_end", end)?.m;
    check_translation(ctx, "camera.transform_end", end, 1)?;
    let m = Motion::new(start, end).map_err(|e| ctx.fail("camera.transform_end", e))?;
    m.check_invertible(shutter).map_err(|e| ctx.fail("camera.transform_end", e))?;
    if m.is_static() {
        return Ok(());
    }
    let motion = CameraMotion { motion: m, from_start: DAffine3::from_mat4(start).inverse() };
    if shutter[0] < shutter[1] {
        camera.motion = Some(Box::new(motion));
    } else if shutter[0] > 0.0 {
        let moved = motion.ray(shutter[0], camera.position, camera.forward);
        let (_, right) = motion.ray(shutter[0], camera.position, camera.right);
        let (_, up) = motion.ray(shutter[0], camera.position, camera.up);
        (camera.position, camera.forward, camera.right, camera.up) = (moved.0, moved.1, right, up);
        if !in_range(camera.position) {
            return Err(ctx.fail("camera.transform_end", "puts the camera out of range at the shutter's time"));
        }
    }
    Ok(())
}
