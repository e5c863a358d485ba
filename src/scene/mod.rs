//! Scenes: the TOML format ([`format`]), loading and validation ([`load`], with the
//! lights and objects in `objects`), transforms ([`transform`]), OBJ and PLY meshes
//! ([`mesh`], [`ply`]), Mitsuba 3 XML import ([`mitsuba`]), and the validated,
//! ready-to-render [`Scene`].

pub mod format;
pub mod load;
pub mod mesh;
pub mod mitsuba;
pub mod ply;
pub mod text;
pub mod transform;
pub mod values;

use glam::{DAffine3, Mat3, Vec2, Vec3};

use crate::accel::Accel;
use crate::accel::BvhQuality;
use crate::bsdf::microfacet::Microfacet;
use crate::bsdf::plastic::Transmittance;
use crate::emitter::environment::Environment;
use crate::motion::Motion;
use crate::simd::{Real, V3};
use crate::texture::Texture;

pub use load::load;
pub use values::SceneSource;

/// The default scene, compiled into the binary: what `wavetrace` renders with no SCENE.
pub const DEFAULT_SCENE: &str = include_str!("../../scenes/default.toml");

/// How anti-aliasing samples are placed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AaMode {
    /// `samples` stratified samples in every pixel.
    Uniform,
    /// The paper's corner method (§2.1): centre and corners, then 2^i stratified rays per
    /// level while the estimate still moves by more than `eps` in display values.
    Adaptive {
        /// Display-value tolerance (max over R, G, B of sRGB values clamped to [0, 1]).
        eps: f32,
        /// First level whose agreement with the previous estimate may stop refinement.
        min_level: u32,
        /// Last level; level i casts 2^i rays.
        max_level: u32,
        /// Trace the (W+1)×(H+1) corner grid once instead of 4 corners per pixel.
        share_corners: bool,
    },
    /// Variance-driven sampling as production renderers do it (Cycles' adaptive
    /// sampling): rounds of `min_samples` stratified samples, each pixel's error
    /// estimated from the difference of its even and odd samples, rounds continuing in
    /// the pixels (and their neighbours) whose error is still above `threshold`, up to
    /// `aa_samples` a pixel.
    Variance {
        /// Error below which a pixel stops (see `render::variance::pixel_error`).
        threshold: f32,
        /// Samples of the first round and of every later one (the last may be cut short).
        min_samples: u32,
    },
    /// Variance-driven or uniform, whichever a pilot pass (`min_samples` in one pixel of
    /// every 8×8 block) predicts needs fewer samples for the error `threshold`; see
    /// `render::uniform_samples`.
    Auto {
        /// The error aimed at, in the variance mode's measure.
        threshold: f32,
        /// The pilot's samples, and the variance rounds' (8 where `aa_samples` leaves
        /// four rounds of 8: `render::variance::auto_round`).
        min_samples: u32,
    },
}

/// How shadow rays towards quad lights are placed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadowMode {
    /// `samples` stratified rays per quad light per shading point.
    Uniform,
    /// The paper's shadow-corner test (§2.2): probe rays first, `samples` rays only for
    /// points in the penumbra.
    Adaptive(Probe),
    /// Adaptive or uniform, whichever casts fewer rays at the penumbra fraction a pilot
    /// pass measures (`render::shadows_pay`).
    Auto(Probe),
}

/// The rays of the adaptive shadow test.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Probe {
    /// The paper's four rays to the light's corners.
    Corners,
    /// The four corners and the light's centre: catches an occluder over the middle.
    CornersCenter,
    /// One ray to a jittered point in each quarter of the light, new per shading point.
    Jittered,
    /// A 3×3 grid: corners, edge midpoints and centre. Catches occluders that cover the
    /// middle of an edge, which the corners straddle.
    Grid3,
}

impl Probe {
    /// Rays per shading point.
    pub fn rays(self) -> u32 {
        match self {
            Probe::Corners | Probe::Jittered => 4,
            Probe::CornersCenter => 5,
            Probe::Grid3 => 9,
        }
    }
}

/// Sampling settings, validated.
#[derive(Clone, Debug)]
pub struct Settings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Maximum reflection/refraction bounces.
    pub max_depth: u32,
    /// Seed of every random decision.
    pub seed: u32,
    /// Anti-aliasing mode.
    pub aa_mode: AaMode,
    /// Anti-aliasing samples per pixel (uniform mode).
    pub aa_samples: u32,
    /// Shadow sampling mode.
    pub shadow_mode: ShadowMode,
    /// Shadow rays per quad light per shading point.
    pub shadow_samples: u32,
    /// Lens samples per pixel sample; forced to 1 for a pinhole camera, so a closed
    /// aperture costs no lens sampling.
    pub dof_samples: u32,
    /// Trace rays in SIMD packets (same hits; a performance choice).
    pub packets: bool,
    /// Blue-noise dithering: the four pixels of each 2×2 block share their paths'
    /// sample sequences ([`crate::sampling::dither`]).
    pub blue_noise: bool,
    /// The BVH build's quality (same hits; a performance choice).
    pub bvh: BvhQuality,
    /// DOF-aware adaptive AA: the blur radius (pixels) from which a pixel is not refined.
    /// `Some` only when it has an effect: adaptive AA, `dof_aware`, an open aperture.
    pub dof_radius: Option<f32>,
    /// Early stopping of penumbra points; `Some` only with adaptive shadows and a
    /// tolerance above 0.
    pub penumbra_stop: Option<PenumbraStop>,
    /// Rough conductors and rough glass sample the area lights too, weighted against
    /// their BSDF's ray by multiple importance sampling (`render.gloss.mis`).
    pub gloss_mis: bool,
    /// Motion blur: the times the shutter opens and closes (`camera.shutter`).
    pub shutter: [f32; 2],
    /// How light reaches the camera (`render.transport`).
    pub transport: Transport,
}

/// How light reaches the camera (docs/transport.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transport {
    /// The paper's: diffuse surfaces take direct light only; mirrors and glass spawn
    /// reflection and refraction rays up to `max_depth` bounces.
    Whitted,
    /// Path tracing (also `direct`, as one bounce): every surface scatters one ray by its
    /// BSDF up to `max_depth` bounces, each diffuse vertex takes next-event estimation.
    Path {
        /// Bounces before Russian roulette may end a path.
        rr_depth: u32,
        /// Emitters and the background seen straight from the camera are black.
        hide_emitters: bool,
    },
}

impl Settings {
    /// True under the path transport.
    #[inline]
    pub fn path(&self) -> bool {
        matches!(self.transport, Transport::Path { .. })
    }
}

/// Early stopping of a penumbra point's shadow rays (`render.shadows.tolerance`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PenumbraStop {
    /// Stop when the half-width of the 95% Wilson interval of the visible fraction is
    /// below this.
    pub tolerance: f32,
    /// Shadow rays per point between two tests.
    pub batch: u32,
}

/// A thin-lens camera with an orthonormal basis.
#[derive(Clone, Debug)]
pub struct Camera {
    /// Centre of the lens.
    pub position: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// Unit vector to the image's right.
    pub right: Vec3,
    /// Unit vector to the image's top.
    pub up: Vec3,
    /// tan(fov_y / 2).
    pub tan_half_fov: f32,
    /// Width / height.
    pub aspect: f32,
    /// Lens radius; 0 is a pinhole.
    pub aperture: f32,
    /// Distance from the lens to the plane in focus, along `forward`.
    pub focus_distance: f32,
    /// How the camera moves over the shutter (`None`: it stays still, and its rays are
    /// generated as they are).
    pub motion: Option<Box<CameraMotion>>,
}

/// A moving camera: rays are generated for the camera at time 0 and carried to where it
/// is at their time.
#[derive(Clone, Debug)]
pub struct CameraMotion {
    /// The camera-to-world transform over time.
    pub motion: Motion,
    /// The inverse of the camera-to-world transform at time 0.
    pub from_start: DAffine3,
}

impl CameraMotion {
    /// A ray (origin, unit direction) of the camera at time 0, as the camera at `time`
    /// casts it.
    #[inline]
    pub fn ray(&self, time: f32, o: Vec3, d: Vec3) -> (Vec3, Vec3) {
        let r = self.motion.at(time) * self.from_start;
        (r.transform_point3(o.as_dvec3()).as_vec3(), r.transform_vector3(d.as_dvec3()).normalize().as_vec3())
    }
}

impl Camera {
    /// Unit direction of the pinhole ray through film position `film` (pixels, y down)
    /// of a `width`×`height` image.
    #[inline]
    pub fn pinhole_dir(&self, film: Vec2, width: u32, height: u32) -> Vec3 {
        self.pinhole_dirs(film.x, film.y, width, height).vec()
    }

    /// [`Camera::pinhole_dir`] on lanes of film positions (`fx`, `fy`): one formula for
    /// both widths, in glam's order of operations, so a lane has the scalar bits.
    #[inline(always)]
    pub fn pinhole_dirs<R: Real>(&self, fx: R, fy: R, width: u32, height: u32) -> V3<R> {
        let (two, one) = (R::splat(2.0), R::splat(1.0));
        let sx = (two * fx / R::splat(width as f32) - one) * R::splat(self.tan_half_fov) * R::splat(self.aspect);
        let sy = (one - two * fy / R::splat(height as f32)) * R::splat(self.tan_half_fov);
        (V3::splat(self.forward) + V3::splat(self.right).scale(sx) + V3::splat(self.up).scale(sy)).normalize()
    }
}

/// How a dielectric splits weight between reflection and refraction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ReflectRatio {
    /// The paper's contribution ratio C: reflection C, refraction 1 - C.
    Fixed(f32),
    /// Exact unpolarised dielectric Fresnel reflectance.
    Fresnel,
}

/// A colour of a material: a constant, or a texture looked up at the hit's UV.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Color {
    /// Linear RGB.
    Rgb(Vec3),
    /// Index into [`Scene::textures`].
    Texture(u32),
}

/// A material, validated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Material {
    /// Lambert (color/π) plus normalised Phong `specular·(n+2)/(2π)·cos^n α`.
    Diffuse {
        /// Albedo.
        color: Color,
        /// Phong reflectance.
        specular: Vec3,
        /// Phong exponent.
        shininess: f32,
        /// Both sides reflect; else the side behind the geometric normal is black.
        two_sided: bool,
    },
    /// Perfect mirror.
    Mirror {
        /// Reflectance.
        color: Vec3,
    },
    /// Smooth dielectric.
    Dielectric {
        /// Index of refraction relative to the outside.
        ior: f32,
        /// Reflection/refraction split.
        ratio: ReflectRatio,
        /// Transmission tint.
        tint: Vec3,
        /// Microfacet roughness; `None`: smooth.
        roughness: Option<Microfacet>,
        /// A thin sheet: transmission goes straight through, reflection is the sheet's
        /// (2R / (1 + R) for a Fresnel reflectance R of one face).
        thin: bool,
    },
    /// A metal: Fresnel reflectance of a complex index of refraction.
    Conductor {
        /// Real part of the index of refraction, per channel.
        eta: Vec3,
        /// Imaginary part, per channel.
        k: Vec3,
        /// Multiplies the Fresnel reflectance.
        color: Color,
        /// Microfacet roughness; `None`: smooth.
        roughness: Option<Microfacet>,
    },
    /// A diffuse base under a dielectric coating (Mitsuba's `plastic`, `roughplastic`).
    Plastic {
        /// Reflectance of the diffuse base.
        color: Color,
        /// Multiplies the coating's reflection.
        specular: Vec3,
        /// The coating's index of refraction over the outside's.
        eta: f32,
        /// The coating's roughness; `None`: smooth.
        roughness: Option<Microfacet>,
        /// The base scaled by 1 / (1 − r·ρ) rather than 1 / (1 − r).
        nonlinear: bool,
        /// Both sides are its front; else the side behind the geometric normal is black.
        two_sided: bool,
        /// The coating's internal diffuse reflectance r.
        internal: f32,
        /// Mitsuba's `specular_sampling_weight`.
        specular_weight: f32,
        /// The rough coating's transmittance: an index into [`Scene::transmittance`].
        table: u32,
    },
}

/// A light source, validated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// One-sided parallelogram emitter.
    Quad {
        /// One corner.
        corner: Vec3,
        /// First edge.
        u: Vec3,
        /// Second edge.
        v: Vec3,
        /// Unit normal of the emitting side (u × v).
        normal: Vec3,
        /// Area.
        area: f32,
        /// Emitted radiance.
        radiance: Vec3,
    },
    /// One-sided triangle emitter: points `v0 + a·e1 + b·e2`, a, b >= 0, a + b <= 1.
    Triangle {
        /// First vertex.
        v0: Vec3,
        /// Second vertex minus the first.
        e1: Vec3,
        /// Third vertex minus the first.
        e2: Vec3,
        /// Unit normal of the emitting side (e1 × e2: counter-clockwise front).
        normal: Vec3,
        /// Area.
        area: f32,
        /// Emitted radiance.
        radiance: Vec3,
    },
    /// Isotropic point light.
    Point {
        /// Position.
        position: Vec3,
        /// Intensity, W/sr.
        intensity: Vec3,
    },
    /// A sphere emitting outwards (Mitsuba's `area` emitter on a `sphere`), sampled by the
    /// solid angle it subtends.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
        /// Emitted radiance, on the outside.
        radiance: Vec3,
    },
    /// Parallel light from infinitely far (Mitsuba's `directional`).
    Directional {
        /// Unit direction the light travels in.
        direction: Vec3,
        /// Irradiance on a surface facing it, W/m².
        irradiance: Vec3,
    },
}

impl Light {
    /// A planar area light that emits (a point, directional or sphere light, or a dark
    /// one, is not): the lights [`Scene::gloss_lights`] holds.
    pub fn lit_area(&self) -> bool {
        match *self {
            Light::Quad { radiance, .. } | Light::Triangle { radiance, .. } => radiance != Vec3::ZERO,
            Light::Point { .. } | Light::Directional { .. } | Light::Sphere { .. } => false,
        }
    }

    /// What the light emits: a point light's intensity, a directional light's
    /// irradiance, an area or sphere light's radiance (zero for a dark light, which casts
    /// no shadow ray).
    pub fn emission(&self) -> Vec3 {
        match *self {
            Light::Point { intensity: e, .. }
            | Light::Directional { irradiance: e, .. }
            | Light::Sphere { radiance: e, .. }
            | Light::Quad { radiance: e, .. }
            | Light::Triangle { radiance: e, .. } => e,
        }
    }

    /// A sphere light that emits.
    pub fn lit_sphere(&self) -> bool {
        matches!(*self, Light::Sphere { radiance, .. } if radiance != Vec3::ZERO)
    }

    /// The planar emitter as (origin, u, v, normal, area, radiance, triangle): points
    /// `origin + a·u + b·v` with a, b in [0, 1] (a + b <= 1 for a triangle). `None` for a
    /// point light.
    #[inline]
    pub fn planar(&self) -> Option<(Vec3, Vec3, Vec3, Vec3, f32, Vec3, bool)> {
        match *self {
            Light::Quad { corner, u, v, normal, area, radiance } => Some((corner, u, v, normal, area, radiance, false)),
            Light::Triangle { v0, e1, e2, normal, area, radiance } => Some((v0, e1, e2, normal, area, radiance, true)),
            Light::Point { .. } | Light::Directional { .. } | Light::Sphere { .. } => None,
        }
    }

    /// The power an area light emits, up to a constant: its area times the luminance of
    /// its radiance (Rec. 709 weights); 0 for a point light.
    pub fn power(&self) -> f32 {
        match *self {
            Light::Quad { radiance, area, .. } | Light::Triangle { radiance, area, .. } => {
                area * radiance.dot(Vec3::new(0.2126, 0.7152, 0.0722))
            }
            Light::Point { .. } | Light::Directional { .. } | Light::Sphere { .. } => 0.0,
        }
    }
}

/// A scene's area lights that light samples pick from (its `gloss_lights`), as columns
/// gathered per lane by the light's position in that list; built once per scene
/// ([`light`](crate::light) samples them).
#[derive(Clone, Debug, Default)]
pub struct AreaLights {
    /// Origin, first edge, second edge, normal and radiance, x y z each.
    pub(crate) c: [Vec<f32>; 15],
    /// The light's area over its pick probability.
    pub(crate) area: Vec<f32>,
    /// Whether it is a triangle (else a parallelogram).
    pub(crate) triangle: Vec<bool>,
}

impl AreaLights {
    /// The table of `gloss` (indices into `lights`, every one an area light), each picked
    /// with probability `pick[li]` (uniformly when `pick` is empty).
    pub fn new(lights: &[Light], gloss: &[u32], pick: &[f32]) -> AreaLights {
        let mut t = AreaLights::default();
        for &li in gloss {
            // Every one is planar (a point light is never among them).
            let zero = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, 0.0, Vec3::ZERO, false);
            let (o, u, v, normal, area, radiance, tri) = lights[li as usize].planar().unwrap_or(zero);
            for (col, x) in t.c.iter_mut().zip([o, u, v, normal, radiance].iter().flat_map(|v| v.to_array())) {
                col.push(x);
            }
            let p = pick.get(li as usize).copied().unwrap_or(1.0 / gloss.len() as f32);
            t.area.push(area / p);
            t.triangle.push(tri);
        }
        t
    }
}

impl Scene {
    /// True when next-event estimation samples the environment: under the path transport,
    /// when it emits.
    pub fn samples_environment(&self) -> bool {
        self.settings.path() && !self.background.is_black()
    }
}

impl Material {
    /// True for the materials that sample the lights themselves (under MIS): rough ones
    /// and plastic, whose diffuse base needs them even under a smooth coating.
    pub fn samples_lights(&self) -> bool {
        self.roughness().is_some() || matches!(self, Material::Plastic { .. })
    }

    /// The microfacet roughness of a rough conductor, rough glass or rough plastic.
    pub fn roughness(&self) -> Option<&Microfacet> {
        match self {
            Material::Conductor { roughness, .. }
            | Material::Dielectric { roughness, .. }
            | Material::Plastic { roughness, .. } => roughness.as_ref(),
            Material::Diffuse { .. } | Material::Mirror { .. } => None,
        }
    }
}

/// Facts about the loaded scene, reported in the stats.
#[derive(Clone, Debug, Default)]
pub struct SceneInfo {
    /// Primitives in the BVH (quad lights included).
    pub primitives: usize,
    /// Triangles from meshes.
    pub triangles: usize,
    /// Zero-area mesh triangles that were skipped.
    pub degenerate_triangles: usize,
    /// BVH build time in seconds.
    pub bvh_seconds: f64,
    /// Mesh files that resolve outside the scene file's folder (through `..` or a
    /// symlink): allowed, but reported.
    pub outside_paths: Vec<String>,
    /// What an imported (Mitsuba XML) scene reads differently from Mitsuba, or ignores.
    pub notes: Vec<String>,
    /// Every file the scene reads besides itself (includes, meshes, textures), each with
    /// what it is for, as a message names it: no output may overwrite one.
    pub inputs: Vec<(String, std::path::PathBuf)>,
}

impl Scene {
    /// True when rays need a time: the shutter is open and something moves. Otherwise
    /// no time is drawn and every ray sees the scene as it is at the shutter's opening.
    #[inline]
    pub fn motion_blur(&self) -> bool {
        let [open, close] = self.settings.shutter;
        open < close && (self.accel.moving().is_some() || self.camera.motion.is_some())
    }
}

/// A validated scene ready to render.
pub struct Scene {
    /// Sampling settings.
    pub settings: Settings,
    /// Camera.
    pub camera: Camera,
    /// Radiance of escaped rays: constant, or an environment map; a light under the path
    /// transport.
    pub background: Environment,
    /// Materials, indexed by `Primitive::material`.
    pub materials: Vec<Material>,
    /// Lights, indexed by `Primitive::light`.
    pub lights: Vec<Light>,
    /// Geometry with its BVH.
    pub accel: Accel,
    /// Vertex normals of smooth-shaded triangles, indexed by primitive id like `accel.prim` (all zero for
    /// a flat primitive); empty when no mesh is smooth.
    pub normals: Vec<[Vec3; 3]>,
    /// Textures, indexed by [`Color::Texture`].
    pub textures: Vec<Texture>,
    /// Texture coordinates of the triangles' corners, indexed by primitive id like `accel.prim` (zero for
    /// a primitive without); empty when no textured material is on a mesh with UVs.
    pub uvs: Vec<[Vec2; 3]>,
    /// Rotations from world directions to a textured sphere's own axes, indexed like
    /// `accel.prim` (identity elsewhere); empty when no textured sphere is rotated.
    pub uv_frames: Vec<Mat3>,
    /// True when some material is a mirror or dielectric (so the scatter stage has work).
    pub has_specular: bool,
    /// The emitting area lights, which rough conductors and rough glass sample under
    /// `settings.gloss_mis`; empty when that is off or no rough material is used, so a
    /// scene without one pays nothing for it.
    pub gloss_lights: Vec<u32>,
    /// Under the path transport, the probability with which a light sample picks each
    /// light (indexed like `lights`; 0 for those not in `gloss_lights`): by power, area
    /// times the luminance of the radiance. Empty: uniform over `gloss_lights`.
    pub light_pick: Vec<f32>,
    /// The running sums of `light_pick` over `gloss_lights`, the last 1; empty with it.
    pub light_cdf: Vec<f32>,
    /// The point and directional lights (indices into `lights`): one ray each wherever
    /// they are sampled.
    pub delta_lights: Vec<u32>,
    /// The emitting sphere lights, each sampled on its own by the light samples of the
    /// path transport and of rough surfaces (when `gloss_lights` would be filled).
    pub sphere_lights: Vec<u32>,
    /// `gloss_lights` as columns for the path transport's light samples on lanes.
    pub area_lights: AreaLights,
    /// The rough plastics' coating transmittance tables ([`Material::Plastic`]'s `table`).
    pub transmittance: Vec<Transmittance>,
    /// Load facts for the stats.
    pub info: SceneInfo,
}
