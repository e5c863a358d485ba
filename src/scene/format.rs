//! Scene format v1: the TOML file as serde types. Every field is documented in
//! docs/scene-format.md with its default; unknown fields are errors.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A whole scene file.
#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Image and sampling settings.
    #[serde(default)]
    pub render: RenderDesc,
    /// The camera.
    pub camera: CameraDesc,
    /// What rays that escape see.
    #[serde(default)]
    pub background: BackgroundDesc,
    /// Named materials.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialDesc>,
    /// Light sources.
    #[serde(default)]
    pub lights: Vec<LightDesc>,
    /// Geometry.
    #[serde(default)]
    pub objects: Vec<ObjectDesc>,
}

/// `[render]`.
#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(deny_unknown_fields, default)]
pub struct RenderDesc {
    /// Image width in pixels (default 320).
    pub width: u32,
    /// Image height in pixels (default 240).
    pub height: u32,
    /// Reflection/refraction bounces (default 6).
    pub max_depth: u32,
    /// Seed of every random decision (default 1).
    pub seed: u32,
    /// Trace in SIMD packets (default true; see docs/performance.md).
    pub packets: bool,
    /// Blue-noise dithering of the camera paths' samples across each 2×2 pixel block
    /// (default false; docs/scene-format.md).
    pub blue_noise: bool,
    /// The BVH build's quality: "auto", "low", "medium" or "high" (default "auto": by the
    /// rays the render will trace per primitive; see docs/performance.md).
    pub bvh: BvhDesc,
    /// Anti-aliasing.
    pub aa: AaDesc,
    /// Soft shadows.
    pub shadows: ShadowsDesc,
    /// Depth of field.
    pub dof: DofDesc,
    /// Glossy surfaces.
    pub gloss: GlossDesc,
    /// Light transport: "whitted" (the paper's), "direct" or "path" (default "whitted";
    /// docs/transport.md).
    pub transport: TransportDesc,
    /// Path transport's Russian roulette and emitter visibility.
    pub path: PathDesc,
}

impl Default for RenderDesc {
    fn default() -> Self {
        RenderDesc {
            width: 320,
            height: 240,
            max_depth: 6,
            seed: 1,
            packets: true,
            blue_noise: false,
            bvh: BvhDesc::Auto,
            aa: AaDesc::default(),
            shadows: ShadowsDesc::default(),
            dof: DofDesc::default(),
            gloss: GlossDesc::default(),
            transport: TransportDesc::Whitted,
            path: PathDesc::default(),
        }
    }
}

/// `[render.aa]`.
#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(deny_unknown_fields, default)]
pub struct AaDesc {
    /// Sampling mode: "uniform", "adaptive" (the paper's corners), "variance" (per-pixel
    /// error from two half-buffers) or "auto" (uniform or variance, as a pilot pass
    /// predicts is cheaper to `threshold`; default "uniform").
    pub mode: SamplingDesc,
    /// Uniform: stratified samples per pixel; variance: the most a pixel gets (default 16).
    pub samples: u32,
    /// Variance: a pixel stops once its estimated error falls below this; auto: the
    /// error aimed at (default 0.01).
    pub threshold: f32,
    /// Variance: samples every pixel gets before its error is first estimated, and the
    /// samples added to each unconverged pixel per round (default 16).
    pub min_samples: u32,
    /// Adaptive: refine while display colours differ by more than this (default 0.01).
    pub eps: f32,
    /// Adaptive: first level at which refinement may stop; the levels before it are
    /// always cast (default 4: at least 4+8+16 samples in a refined pixel; 2 is the
    /// paper's literal rule, level 2 compared with the corner mean).
    pub min_level: u32,
    /// Adaptive: last refinement level; level i casts 2^i rays (default 6: up to 64).
    pub max_level: u32,
    /// Adaptive: trace the pixel-corner grid once and share it (default true).
    pub share_corners: bool,
    /// Adaptive, open aperture: raise each pixel's eps with its blur and scale each
    /// point's lens samples with it (the paper's §5 proposal; default false).
    pub dof_aware: bool,
    /// Adaptive with `dof_aware`: the circle-of-confusion radius, in pixels, from which a
    /// pixel is not refined for anti-aliasing at all (default 2).
    pub dof_radius: f32,
}

impl Default for AaDesc {
    fn default() -> Self {
        AaDesc {
            mode: SamplingDesc::Uniform,
            samples: 16,
            threshold: 0.01,
            min_samples: 16,
            eps: 0.01,
            min_level: 4,
            max_level: 6,
            share_corners: true,
            dof_aware: false,
            dof_radius: 2.0,
        }
    }
}

/// `[render.shadows]`.
#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(deny_unknown_fields, default)]
pub struct ShadowsDesc {
    /// Sampling mode: "uniform", "adaptive", or "auto": adaptive where a pilot pass
    /// measures a penumbra small enough for the probes to save rays (default "uniform").
    pub mode: SamplingDesc,
    /// Shadow rays per quad light per shading point (uniform), or per penumbra point
    /// (adaptive) (default 16).
    pub samples: u32,
    /// Adaptive: the rays of the shadow-corner test: "corners" (the paper's four),
    /// "corners+center", "jittered" or "3x3" (default "3x3": corners, edge midpoints and
    /// centre, which the measurements in docs/adaptive.md favour).
    pub probe: ProbeDesc,
    /// Adaptive: stop a penumbra point's samples once the 95% Wilson interval of its
    /// visible fraction is narrower than ± this (default 0: off, always `samples`).
    pub tolerance: f32,
    /// Adaptive with a tolerance: shadow rays per penumbra point between two tests
    /// (default 16).
    pub batch: u32,
}

impl Default for ShadowsDesc {
    fn default() -> Self {
        ShadowsDesc { mode: SamplingDesc::Uniform, samples: 16, probe: ProbeDesc::Grid3, tolerance: 0.0, batch: 16 }
    }
}

/// `render.bvh`: "auto", "low", "medium" or "high".
#[derive(Deserialize, Serialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum BvhDesc {
    /// Chosen by the ray budget: the build that gives the finished image soonest.
    Auto,
    /// The fastest build, for renders that trace few rays per primitive.
    Low,
    /// A faster build, slower incoherent traversal.
    Medium,
    /// A slower build, faster incoherent traversal.
    High,
}

/// `render.aa.mode` and `render.shadows.mode`: "uniform", "adaptive", "auto" or
/// (anti-aliasing only) "variance".
#[derive(Deserialize, Serialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum SamplingDesc {
    /// The same number of rays everywhere.
    Uniform,
    /// Rays where the adaptive test finds an edge or a penumbra.
    Adaptive,
    /// Anti-aliasing only: more samples where two half-buffers disagree.
    Variance,
    /// The cheaper of the others for the scene, chosen by a pilot pass.
    Auto,
}

/// `render.shadows.probe`: the rays of the adaptive shadow-corner test.
#[derive(Deserialize, Serialize, Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProbeDesc {
    /// "corners": the light's four corners (the paper's test).
    #[serde(rename = "corners")]
    Corners,
    /// "corners+center": the corners and the centre.
    #[serde(rename = "corners+center")]
    CornersCenter,
    /// "jittered": one jittered point in each quarter of the light.
    #[serde(rename = "jittered")]
    Jittered,
    /// "3x3": corners, edge midpoints and centre.
    #[serde(rename = "3x3")]
    Grid3,
}

/// `[render.dof]`.
#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(deny_unknown_fields, default)]
pub struct DofDesc {
    /// Lens samples per pixel sample when the aperture is open (default 1).
    pub samples: u32,
}

impl Default for DofDesc {
    fn default() -> Self {
        DofDesc { samples: 1 }
    }
}

/// `[render.gloss]`.
#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(deny_unknown_fields, default)]
pub struct GlossDesc {
    /// Multiple importance sampling at rough conductors and rough glass: each glossy hit
    /// also samples one point on an area light, and the light sample and the BSDF's ray
    /// are weighted by the power heuristic (default true; false: the BSDF's ray alone).
    pub mis: bool,
}

impl Default for GlossDesc {
    fn default() -> Self {
        GlossDesc { mis: true }
    }
}

/// `render.transport`: how light reaches the camera (docs/transport.md).
#[derive(Deserialize, Serialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum TransportDesc {
    /// The paper's: direct light at diffuse surfaces, mirror and glass chains.
    Whitted,
    /// Direct light only, at every surface the camera sees (Mitsuba's `direct`): the
    /// path transport with one bounce.
    Direct,
    /// Path tracing: every surface scatters, with next-event estimation and multiple
    /// importance sampling (Mitsuba's `path`).
    Path,
}

/// `[render.path]`.
#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(deny_unknown_fields, default)]
pub struct PathDesc {
    /// Bounces before Russian roulette may end a path (default 5, as Mitsuba's
    /// `rr_depth`; counted as `max_depth` is).
    pub rr_depth: u32,
    /// Emitters and the background seen straight from the camera are black (Mitsuba's
    /// `hide_emitters`; default false).
    pub hide_emitters: bool,
}

impl Default for PathDesc {
    fn default() -> Self {
        PathDesc { rr_depth: 5, hide_emitters: false }
    }
}

/// `[camera]`.
#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    /// Eye position (required unless `transform` is given).
    #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "exact::opt::position")]
    pub position: Option<[f32; 3]>,
    /// Point the camera looks at (required unless `transform` is given).
    #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "exact::opt::look_at")]
    pub look_at: Option<[f32; 3]>,
    /// Up hint (default [0, 1, 0]).
    #[serde(default = "default_up", deserialize_with = "exact::up")]
    pub up: [f32; 3],
    /// Camera-to-world transform instead of position/look_at/up, with Mitsuba's camera
    /// frame: the camera sits at the origin looking along +z with +y up (+x is to the
    /// image's left). Default: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transform: Option<Vec<TransformOp>>,
    /// Vertical field of view in degrees (default 40).
    #[serde(default = "default_fov")]
    pub fov_y: f32,
    /// Thin-lens radius in scene units; 0 is a pinhole (default 0).
    #[serde(default)]
    pub aperture: f32,
    /// Distance of the plane in focus (default |look_at - position|, or 1 with a
    /// `transform`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub focus_distance: Option<f32>,
    /// Motion blur: the times in [0, 1] the shutter opens and closes; a camera ray's
    /// time is uniform over them, stratified over the pixel (default [0, 0]: no motion
    /// blur, everything where it is at time 0).
    #[serde(default, deserialize_with = "exact::shutter")]
    pub shutter: [f32; 2],
    /// The camera-to-world transform at time 1 (the same syntax as `transform`, with
    /// the same camera frame); the camera at time 0 is `transform`, or
    /// position/look_at/up (default: none, the camera stays still).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transform_end: Option<Vec<TransformOp>>,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

fn default_fov() -> f32 {
    40.0
}

/// `[background]`.
#[derive(Deserialize, Serialize, Debug, Clone, Default)]
#[serde(deny_unknown_fields, default)]
pub struct BackgroundDesc {
    /// Radiance of rays that hit nothing (default black; with `map`, its factor, default
    /// white).
    #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "exact::opt::color")]
    pub color: Option<[f32; 3]>,
    /// A latitude-longitude environment map (EXR or PNG, relative to the scene file), in
    /// Mitsuba's `envmap` convention: the image's top row is +y, its centre column −z.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map: Option<String>,
    /// Multiplies the map (Mitsuba's `scale`; default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<f32>,
    /// A rotation of the map into the world (Mitsuba's `to_world`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transform: Option<Vec<TransformOp>>,
}

/// serde's default for flags that are on unless given.
fn yes() -> bool {
    true
}

/// `[materials.NAME]`.
#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum MaterialDesc {
    /// Lambertian with an optional normalised Phong highlight.
    Diffuse {
        /// Albedo: an RGB triple or a texture.
        color: ColorDesc,
        /// Phong specular reflectance (default 0).
        #[serde(default, deserialize_with = "exact::specular")]
        specular: [f32; 3],
        /// Phong exponent (default 0; only used when `specular` is non-zero).
        #[serde(default)]
        shininess: f32,
        /// Both sides reflect (default true); false: black seen from behind its normal,
        /// as Mitsuba's `diffuse` without `twosided`.
        #[serde(default = "yes")]
        two_sided: bool,
    },
    /// Perfect mirror.
    Mirror {
        /// Reflectance.
        #[serde(deserialize_with = "exact::color")]
        color: [f32; 3],
    },
    /// Smooth glass.
    Dielectric {
        /// Index of refraction relative to the outside medium.
        ior: f32,
        /// The paper's C, or "fresnel" (default "fresnel").
        #[serde(default, skip_serializing_if = "Option::is_none")]
        reflect_ratio: Option<RatioDesc>,
        /// Transmission tint (default white).
        #[serde(default = "white", deserialize_with = "exact::color")]
        color: [f32; 3],
        // The four roughness fields repeat in `Conductor`: serde's `flatten` does not
        // combine with `deny_unknown_fields`, which keeps a misspelt key an error.
        /// A thin sheet (Mitsuba's `thindielectric`): light passes straight through,
        /// and reflection sums the sheet's internal bounces (default false; smooth only).
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        thin: bool,
        /// Rough glass: the microfacet distribution, "ggx" or "beckmann" (default
        /// "beckmann", as Mitsuba's `roughdielectric`; only with a roughness).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        distribution: Option<String>,
        /// Isotropic roughness (the distribution's alpha); absent: smooth glass.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        alpha: Option<f32>,
        /// Roughness along the surface's first tangent (with `alpha_v`, instead of `alpha`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        alpha_u: Option<f32>,
        /// Roughness along the second tangent.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        alpha_v: Option<f32>,
    },
    /// A metal: Fresnel reflection with a complex index of refraction, smooth (a mirror
    /// tinted by Fresnel) or rough (a microfacet distribution).
    Conductor {
        /// Mitsuba's name of a measured metal ("Au", "Ag", "Al", "Cu", "Cr", ...), or
        /// "none" for a perfect reflector; default "none" unless `eta` and `k` are given.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        material: Option<String>,
        /// Real part of the index of refraction per RGB channel (with `k`, instead of
        /// `material`).
        #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "exact::opt::eta")]
        eta: Option<[f32; 3]>,
        /// Imaginary part (absorption) per channel.
        #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "exact::opt::k")]
        k: Option<[f32; 3]>,
        /// Multiplies the Fresnel reflectance (Mitsuba's `specular_reflectance`): an RGB
        /// triple or a texture (default white).
        #[serde(default = "white_color")]
        color: ColorDesc,
        /// The microfacet distribution, "ggx" or "beckmann" (default "beckmann"; only
        /// with a roughness).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        distribution: Option<String>,
        /// Isotropic roughness; absent: a smooth conductor.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        alpha: Option<f32>,
        /// Roughness along the surface's first tangent (with `alpha_v`, instead of `alpha`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        alpha_u: Option<f32>,
        /// Roughness along the second tangent.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        alpha_v: Option<f32>,
    },
    /// A diffuse base under a dielectric coating (Mitsuba's `plastic`, and its
    /// `roughplastic` with a roughness).
    Plastic {
        /// Reflectance of the base (Mitsuba's `diffuse_reflectance`): an RGB triple or a
        /// texture.
        color: ColorDesc,
        /// Multiplies the coating's reflection (Mitsuba's `specular_reflectance`; default
        /// white).
        #[serde(default = "white", deserialize_with = "exact::color")]
        specular: [f32; 3],
        /// The coating's index of refraction over the outside's (default 1.49 / 1.00028,
        /// Mitsuba's polypropylene in air).
        #[serde(default = "plastic_ior")]
        ior: f32,
        /// Scale the base by 1 / (1 − r·ρ), not 1 / (1 − r) (Mitsuba's `nonlinear`).
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        nonlinear: bool,
        /// Both sides are its front (default true); false: black from behind, as Mitsuba's
        /// plastics without `twosided`.
        #[serde(default = "yes")]
        two_sided: bool,
        /// The coating's microfacet distribution, "ggx" or "beckmann" (default
        /// "beckmann"; only with a roughness).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        distribution: Option<String>,
        /// The coating's isotropic roughness; absent: a smooth coating.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        alpha: Option<f32>,
    },
}

/// Mitsuba's default plastic coating: polypropylene (1.49) in air (1.00028).
fn plastic_ior() -> f32 {
    1.49 / 1.00028
}

fn white_color() -> ColorDesc {
    ColorDesc::Rgb(white())
}

/// A colour: an RGB triple, or a texture table looked up at the surface's UV.
#[derive(Serialize, Debug, Clone, PartialEq)]
#[serde(untagged)]
pub enum ColorDesc {
    /// `[r, g, b]`, linear.
    Rgb([f32; 3]),
    /// `{ type = "bitmap", ... }` or `{ type = "checkerboard", ... }`.
    Texture(TextureDesc),
}

impl<'de> Deserialize<'de> for ColorDesc {
    /// Numbers of any count first, so a triple of the wrong length is refused as one
    /// (`color` takes 3 numbers) rather than as "no variant matched".
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum ColorOrTexture {
            Numbers(Vec<f32>),
            Texture(TextureDesc),
        }
        match ColorOrTexture::deserialize(d)? {
            ColorOrTexture::Numbers(v) => {
                let n = v.len();
                let rgb = v.try_into().map_err(|_| {
                    serde::de::Error::custom(format!("`color` takes 3 numbers (or a texture table), not {n}"))
                })?;
                Ok(ColorDesc::Rgb(rgb))
            }
            ColorOrTexture::Texture(t) => Ok(ColorDesc::Texture(t)),
        }
    }
}

/// A texture in a colour's place.
#[derive(Deserialize, Serialize, Debug, Clone, PartialEq)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum TextureDesc {
    /// An image file (PNG, or EXR with the `exr` feature).
    Bitmap {
        /// Path relative to the scene file.
        file: String,
        /// Read the values as they are stored (default false: an 8-bit image is sRGB
        /// and decoded to linear; EXR is always linear).
        #[serde(default)]
        raw: bool,
        /// "repeat", "mirror" or "clamp" (default "repeat").
        #[serde(default, skip_serializing_if = "Option::is_none")]
        wrap: Option<String>,
        /// "bilinear" or "nearest" (default "bilinear").
        #[serde(default, skip_serializing_if = "Option::is_none")]
        filter: Option<String>,
        /// Applied to the UV before the lookup, as a transform list acting on (u, v, 0)
        /// (default: none).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        to_uv: Option<Vec<TransformOp>>,
    },
    /// Two colours in checks of the unit UV square, as Mitsuba's `checkerboard`.
    Checkerboard {
        /// First colour (default 0.4, as Mitsuba).
        #[serde(default = "checker0", deserialize_with = "exact::color0")]
        color0: [f32; 3],
        /// Second colour (default 0.2).
        #[serde(default = "checker1", deserialize_with = "exact::color1")]
        color1: [f32; 3],
        /// Applied to the UV before the lookup (default: none).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        to_uv: Option<Vec<TransformOp>>,
    },
}

fn checker0() -> [f32; 3] {
    [0.4; 3]
}

fn checker1() -> [f32; 3] {
    [0.2; 3]
}

fn white() -> [f32; 3] {
    [1.0, 1.0, 1.0]
}

/// `reflect_ratio`: a number in [0, 1] or the string "fresnel".
///
/// The name stays a string checked when the scene is built, unlike the `render` modes:
/// materials are internally tagged (`type = "..."`), and serde buffers such a table
/// before it picks the variant, so an error raised while parsing a value inside it can
/// only point at the table's header. The check in `load` points at the value.
#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(untagged)]
pub enum RatioDesc {
    /// A fixed ratio C.
    Value(f32),
    /// A name; only "fresnel" is valid.
    Name(String),
}

/// `[[lights]]`.
#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum LightDesc {
    /// One-sided parallelogram emitter.
    Quad {
        /// One corner.
        #[serde(deserialize_with = "exact::corner")]
        corner: [f32; 3],
        /// First edge.
        #[serde(deserialize_with = "exact::edge_u")]
        edge_u: [f32; 3],
        /// Second edge; emits towards `edge_u × edge_v` (after `transform`).
        #[serde(deserialize_with = "exact::edge_v")]
        edge_v: [f32; 3],
        /// Emitted radiance.
        #[serde(deserialize_with = "exact::radiance")]
        radiance: [f32; 3],
        /// Applied to the corner and the edges (default: none).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        transform: Option<Vec<TransformOp>>,
        /// Refused: lights stay still (a key here is an error that says so).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        transform_end: Option<Vec<TransformOp>>,
    },
    /// One-sided triangle emitter; emits towards `(v1 - v0) × (v2 - v0)` (counter-clockwise
    /// front).
    Triangle {
        /// First vertex.
        #[serde(deserialize_with = "exact::v0")]
        v0: [f32; 3],
        /// Second vertex.
        #[serde(deserialize_with = "exact::v1")]
        v1: [f32; 3],
        /// Third vertex.
        #[serde(deserialize_with = "exact::v2")]
        v2: [f32; 3],
        /// Emitted radiance.
        #[serde(deserialize_with = "exact::radiance")]
        radiance: [f32; 3],
        /// Applied to the vertices (default: none).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        transform: Option<Vec<TransformOp>>,
        /// Refused: lights stay still (a key here is an error that says so).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        transform_end: Option<Vec<TransformOp>>,
    },
    /// Isotropic point light.
    Point {
        /// Position.
        #[serde(deserialize_with = "exact::position")]
        position: [f32; 3],
        /// Radiant intensity, W/sr.
        #[serde(deserialize_with = "exact::intensity")]
        intensity: [f32; 3],
        /// Refused: lights stay still (a key here is an error that says so).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        transform_end: Option<Vec<TransformOp>>,
    },
    /// A sphere emitting outwards (Mitsuba's area emitter on a sphere).
    Sphere {
        /// Centre.
        #[serde(deserialize_with = "exact::center")]
        center: [f32; 3],
        /// Radius (> 0).
        radius: f32,
        /// Radiance on the outside.
        #[serde(deserialize_with = "exact::radiance")]
        radiance: [f32; 3],
    },
    /// Parallel light from infinitely far away (Mitsuba's `directional`).
    Directional {
        /// The direction the light travels in (normalised; must be non-zero).
        #[serde(deserialize_with = "exact::direction")]
        direction: [f32; 3],
        /// Irradiance on a surface facing the light, W/m².
        #[serde(deserialize_with = "exact::irradiance")]
        irradiance: [f32; 3],
    },
}

/// `[[objects]]`.
#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum ObjectDesc {
    /// A sphere.
    Sphere {
        /// Centre.
        #[serde(deserialize_with = "exact::center")]
        center: [f32; 3],
        /// Radius.
        radius: f32,
        /// Material name.
        material: String,
        /// Applied to the centre; its linear part must be a uniform scale times a rotation,
        /// which scales the radius (default: none).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        transform: Option<Vec<TransformOp>>,
        /// The transform at time 1 of the shutter, the same syntax as `transform` (which
        /// is the transform at time 0, identity when absent); in between, translation,
        /// rotation and scale are interpolated separately (default: none, the object
        /// stays still).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        transform_end: Option<Vec<TransformOp>>,
    },
    /// A two-sided parallelogram.
    Quad {
        /// One corner.
        #[serde(deserialize_with = "exact::corner")]
        corner: [f32; 3],
        /// First edge.
        #[serde(deserialize_with = "exact::edge_u")]
        edge_u: [f32; 3],
        /// Second edge.
        #[serde(deserialize_with = "exact::edge_v")]
        edge_v: [f32; 3],
        /// Material name.
        material: String,
        /// Applied to the corner and the edges (default: none).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        transform: Option<Vec<TransformOp>>,
        /// The transform at time 1 of the shutter, the same syntax as `transform` (which
        /// is the transform at time 0, identity when absent); in between, translation,
        /// rotation and scale are interpolated separately (default: none, the object
        /// stays still).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        transform_end: Option<Vec<TransformOp>>,
        /// Texture coordinates at the corner, at corner + edge_u and at corner + edge_v
        /// (default `[[0, 0], [1, 0], [0, 1]]`: the point's (a, b)).
        #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "exact::opt::uv")]
        uv: Option<[[f32; 2]; 3]>,
    },
    /// A triangle mesh from an OBJ or PLY file (by extension).
    Mesh {
        /// Path relative to the scene file.
        file: String,
        /// Material name (ignored with `emission`).
        #[serde(default)]
        material: String,
        /// Uniform scale (default 1).
        #[serde(default = "one")]
        scale: f32,
        /// Rotation about +y in degrees, applied after scaling (default 0).
        #[serde(default)]
        rotate_y: f32,
        /// Translation, applied after `rotate_y` (default 0).
        #[serde(default, deserialize_with = "exact::translate")]
        translate: [f32; 3],
        /// Applied after scale, rotate_y and translate (default: none).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        transform: Option<Vec<TransformOp>>,
        /// The transform at time 1 of the shutter, the same syntax as `transform` (which
        /// is the transform at time 0, identity when absent); in between, translation,
        /// rotation and scale are interpolated separately (default: none, the object
        /// stays still).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        transform_end: Option<Vec<TransformOp>>,
        /// Interpolated vertex normals for shading: the file's, or computed from the faces
        /// as Mitsuba 3 does (angle-weighted) when it has none (default false: flat).
        #[serde(default)]
        smooth: bool,
        /// Makes every triangle a one-sided emitter of this radiance (counter-clockwise
        /// front); `material` is then not needed (default: none).
        #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "exact::opt::emission")]
        emission: Option<[f32; 3]>,
        /// Flip the winding (which side emits, and the file's normals) (default false).
        #[serde(default)]
        flip_normals: bool,
    },
}

fn one() -> f32 {
    1.0
}

/// One step of a `transform` list; steps apply in list order (each later one after the
/// ones before, as Mitsuba composes the children of `<transform>`).
#[derive(Deserialize, Serialize, Debug, Clone, PartialEq)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
pub enum TransformOp {
    /// `{ translate = [x, y, z] }`.
    Translate(#[serde(deserialize_with = "exact::translate")] [f32; 3]),
    /// `{ scale = [x, y, z] }` (a uniform scale repeats one number).
    Scale(#[serde(deserialize_with = "exact::scale")] [f32; 3]),
    /// `{ rotate = { axis = [x, y, z], angle = DEGREES } }`: right-handed about `axis`.
    Rotate {
        /// Axis (normalised here).
        #[serde(deserialize_with = "exact::axis")]
        axis: [f32; 3],
        /// Angle in degrees.
        angle: f32,
    },
    /// `{ matrix = [16 numbers] }`: a 4×4 matrix, row by row.
    Matrix(Vec<f32>),
    /// `{ lookat = { origin, target, up } }`: Mitsuba's look-at frame (+z towards the
    /// target, +y up, +x = up × z).
    Lookat {
        /// Where the frame sits.
        #[serde(deserialize_with = "exact::origin")]
        origin: [f32; 3],
        /// Where +z points to.
        #[serde(deserialize_with = "exact::target")]
        target: [f32; 3],
        /// Up hint.
        #[serde(deserialize_with = "exact::up")]
        up: [f32; 3],
    },
}

mod exact;
