//! Tools built on the renderer: they call [`crate::render()`] or the stages, and nothing in
//! the renderer core depends on them. Cargo features (all on by default) gate the parts
//! with heavy or optional dependencies: `flip`, `plot` and `exr` (EXR in [`output`] and
//! [`compare`]).
//!
//! - [`output`]: writing images (PNG, EXR) and text files atomically;
//! - [`heatmap`]: debug images of where the adaptive queues spent rays;
//! - [`compare`]: image error metrics (RMSE, relative MSE, PSNR, mean FLIP);
//! - `flip`: NVIDIA's LDR-FLIP perceptual difference (feature `flip`);
//! - [`sweep`]: error against rays and seconds over a cross product of settings;
//! - [`study`]: where adaptive sampling pays: each method's cheapest setting per target
//!   error, scene by scene, against the scene features;
//! - `plot`: the sweep's scatter plots (feature `plot`);
//! - [`bench`](mod@bench): traversal-kernel throughput on fixed ray sets;
//! - [`merge`]: tile headers, and the exact merge of a render's tiles.
//! - [`bench_mesh`]: the ray sets around a bare mesh, a generated sphere, `.npy` export.
//! - [`kernels`]: the traversal kernels kept to be measured against the renderer's.

pub mod bench;
pub mod bench_mesh;
pub mod compare;
#[cfg(feature = "flip")]
pub mod flip;
pub mod heatmap;
pub mod kernels;
pub mod merge;
pub mod output;
#[cfg(feature = "plot")]
pub mod plot;
pub mod study;
pub mod sweep;
