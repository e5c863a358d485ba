//! Affine transforms from `transform` lists (TOML) and `<transform>` elements (Mitsuba
//! XML), composed the way Mitsuba composes them: each step applies after the ones before.
//! Composition is in f64; points, vectors and normals come out in f32.

use glam::{DMat3, DMat4, DVec3, Vec3};

use super::format::TransformOp;

/// An invertible affine transform.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// The matrix (column vectors; the last row is 0 0 0 1).
    pub m: DMat4,
}

fn d(a: [f32; 3]) -> DVec3 {
    DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64)
}

/// Mitsuba's look-at frame: columns left = up × dir, up' = dir × left, dir, origin.
pub fn look_at(origin: DVec3, target: DVec3, up: DVec3) -> Result<DMat4, String> {
    let dir = (target - origin).normalize_or_zero();
    let left = up.cross(dir).normalize_or_zero();
    if dir == DVec3::ZERO || left == DVec3::ZERO {
        return Err("lookat: target equals origin, or up is parallel to the view direction".into());
    }
    let new_up = dir.cross(left);
    Ok(DMat4::from_cols(left.extend(0.0), new_up.extend(0.0), dir.extend(0.0), origin.extend(1.0)))
}

impl Transform {
    /// The identity.
    pub const IDENTITY: Transform = Transform { m: DMat4::IDENTITY };

    /// One step as a matrix; errors say what is wrong with it.
    pub fn step(op: &TransformOp) -> Result<DMat4, String> {
        Ok(match op {
            TransformOp::Translate(t) => DMat4::from_translation(d(*t)),
            TransformOp::Scale(s) => {
                if s.contains(&0.0) {
                    return Err(format!("scale {s:?} has a zero factor: the shape would be flat"));
                }
                DMat4::from_scale(d(*s))
            }
            TransformOp::Rotate { axis, angle } => {
                let a = d(*axis);
                if a.length_squared() == 0.0 {
                    return Err("rotate: the axis is zero".into());
                }
                DMat4::from_axis_angle(a.normalize(), (*angle as f64).to_radians())
            }
            TransformOp::Matrix(v) => {
                if v.len() != 16 {
                    return Err(format!("matrix has {} numbers, not 16", v.len()));
                }
                let r: Vec<f64> = v.iter().map(|&x| x as f64).collect();
                if r[12..15] != [0.0, 0.0, 0.0] || r[15] != 1.0 {
                    return Err("matrix: the last row must be 0 0 0 1 (projective transforms are not supported)".into());
                }
                DMat4::from_cols_array(&[
                    r[0], r[4], r[8], r[12], r[1], r[5], r[9], r[13], r[2], r[6], r[10], r[14], r[3], r[7], r[11],
                    r[15],
                ])
            }
            TransformOp::Lookat { origin, target, up } => look_at(d(*origin), d(*target), d(*up))?,
        })
    }

    /// Composes `ops` in order (`M = op_n · … · op_1`). Errors name the step (0-based).
    pub fn from_ops(ops: &[TransformOp]) -> Result<Transform, (usize, String)> {
        let mut m = DMat4::IDENTITY;
        for (i, op) in ops.iter().enumerate() {
            m = Transform::step(op).map_err(|e| (i, e))? * m;
        }
        let det = DMat3::from_mat4(m).determinant();
        if !(det.is_finite() && det.abs() > 1e-30 && m.is_finite()) {
            return Err((ops.len().saturating_sub(1), "the transform is singular or not finite".into()));
        }
        Ok(Transform { m })
    }

    /// `self` applied after `first`.
    pub fn after(&self, first: &Transform) -> Transform {
        Transform { m: self.m * first.m }
    }

    /// A point.
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.m.transform_point3(p.as_dvec3()).as_vec3()
    }

    /// A direction or an edge.
    pub fn vector(&self, v: Vec3) -> Vec3 {
        self.m.transform_vector3(v.as_dvec3()).as_vec3()
    }

    /// A normal (by the inverse transpose), normalised.
    pub fn normal(&self, n: Vec3) -> Vec3 {
        let inv_t = DMat3::from_mat4(self.m).inverse().transpose();
        (inv_t * n.as_dvec3()).normalize_or_zero().as_vec3()
    }

    /// True when the transform mirrors (negative determinant): it turns a
    /// counter-clockwise front into a clockwise one.
    pub fn mirrors(&self) -> bool {
        DMat3::from_mat4(self.m).determinant() < 0.0
    }

    /// The factor of a uniform scale (times a rotation, perhaps mirrored), or `None` when
    /// the linear part scales the axes differently or shears (relative tolerance 1e-5).
    pub fn uniform_scale(&self) -> Option<f32> {
        let l = DMat3::from_mat4(self.m);
        let s2 = (l.transpose() * l).to_cols_array();
        let s = (s2[0] + s2[4] + s2[8]) / 3.0;
        let tol = 1e-5 * s;
        let ok = [s2[0] - s, s2[4] - s, s2[8] - s, s2[1], s2[2], s2[5]].iter().all(|x| x.abs() <= tol);
        ok.then(|| s.sqrt() as f32)
    }

    /// The image of the camera frame: (position, forward = +z, up = +y, left = +x).
    pub fn frame(&self) -> (Vec3, Vec3, Vec3, Vec3) {
        let c = |i: usize| self.m.col(i).truncate().as_vec3();
        (c(3), c(2), c(1), c(0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_compose_in_document_order() {
        // Scale by 2, then rotate 90° about z, then translate by (1, 0, 0): the point
        // (1, 0, 0) goes to (2, 0, 0), then (0, 2, 0), then (1, 2, 0).
        let ops = [
            TransformOp::Scale([2.0; 3]),
            TransformOp::Rotate { axis: [0.0, 0.0, 1.0], angle: 90.0 },
            TransformOp::Translate([1.0, 0.0, 0.0]),
        ];
        let t = Transform::from_ops(&ops).unwrap();
        assert!(t.point(Vec3::X).abs_diff_eq(Vec3::new(1.0, 2.0, 0.0), 1e-6));
        // The hand-computed matrix, row by row.
        let want = [0.0, -2.0, 0.0, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0];
        let m = Transform::from_ops(&[TransformOp::Matrix(want.to_vec())]).unwrap();
        assert!(t.m.abs_diff_eq(m.m, 1e-12), "{:?}", t.m);
        assert_eq!(t.uniform_scale(), Some(2.0));
        assert!(!t.mirrors());
    }

    #[test]
    fn look_at_frame_and_bad_steps() {
        let t = Transform::from_ops(&[TransformOp::Lookat {
            origin: [0.0, 0.0, 5.0],
            target: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
        }])
        .unwrap();
        let (p, fwd, up, left) = t.frame();
        assert_eq!((p, fwd, up), (Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z, Vec3::Y));
        // Looking down -z with +y up, the image's left is -x.
        assert!(left.abs_diff_eq(Vec3::NEG_X, 1e-12));
        let non_uniform = Transform::from_ops(&[TransformOp::Scale([1.0, 2.0, 1.0])]).unwrap();
        assert_eq!(non_uniform.uniform_scale(), None);
        assert!(Transform::from_ops(&[TransformOp::Scale([-1.0, 1.0, 1.0])]).unwrap().mirrors());
        assert!(Transform::from_ops(&[TransformOp::Matrix(vec![1.0; 3])]).unwrap_err().1.contains("16"));
        let zero_axis = TransformOp::Rotate { axis: [0.0; 3], angle: 3.0 };
        assert_eq!(Transform::from_ops(&[TransformOp::Translate([1.0; 3]), zero_axis]).unwrap_err().0, 1);
    }
}
