//! The renders of a sweep: the reference when it is not at hand, then every point,
//! measured against it.

use std::path::Path;

use super::plan::{Plan, ReferenceSource};
use super::{describe, overrides, Mode, Point, ReferenceInfo};
use crate::film::Image;
use crate::scene::{load, SceneSource};
use crate::tools::compare::metrics;
use crate::tools::output::write_image;
use crate::{render, Error, RenderOptions, RenderOutput, Result};

impl Plan<'_> {
    /// The reference image and its report: the image at hand, or a new render written to
    /// the cache path.
    pub(super) fn reference(
        &self,
        source: ReferenceSource,
        render_opts: &RenderOptions,
        progress: &Progress,
    ) -> Result<(Image, ReferenceInfo)> {
        let mut info = ReferenceInfo {
            path: source.path,
            spp: source.spp,
            rendered: false,
            overrides: source.overrides,
            seconds: None,
            total_rays: None,
        };
        let image = match source.image {
            Some(img) => img,
            None => {
                progress.say("reference".into());
                let out = render_reference(&self.src, &self.reference_sets(&info.overrides), &info.path, render_opts)?;
                progress.step();
                info.rendered = true;
                info.seconds = Some(out.seconds);
                info.total_rays = Some(out.stats.total_rays());
                out.image
            }
        };
        Ok((image, info))
    }

    /// Renders every point and measures it against `reference` (read from `ref_path`,
    /// named in errors). Also returns the worker threads of the renders.
    pub(super) fn measure(
        &self,
        reference: &Image,
        ref_path: &Path,
        render_opts: &RenderOptions,
        progress: &Progress,
    ) -> Result<(Vec<Point>, usize)> {
        let mut rows = Vec::with_capacity(self.points.len());
        let mut threads = self.opts.threads.unwrap_or(0);
        for point in &self.points {
            progress.say(describe(point));
            let scene = load(&self.src, &overrides(&self.opts.sets, point))?;
            let out = render(&scene, render_opts)?;
            threads = out.per_thread.len();
            let m = metrics(&out.image, reference).map_err(|e| {
                Error::input(format!("sweep point {} against `{}`: {e}", describe(point), ref_path.display()))
            })?;
            let total = out.stats.total_rays();
            rows.push(Point {
                params: point.clone(),
                mode: Mode::of(&scene.settings),
                total_rays: total,
                rays: out.stats.kinds().iter().map(|&(k, n)| (k.to_string(), n)).collect(),
                seconds: out.seconds,
                mrays_per_s: if out.seconds > 0.0 { total as f64 / out.seconds / 1e6 } else { 0.0 },
                metrics: m,
                pareto_rays: false,
                pareto_seconds: false,
            });
            progress.step();
        }
        Ok((rows, threads))
    }
}

/// Loads the scene with `sets` (the reference's), renders it and writes the image to the
/// cache file `path`.
pub(crate) fn render_reference(
    src: &SceneSource,
    sets: &[String],
    path: &Path,
    render_opts: &RenderOptions,
) -> Result<RenderOutput> {
    let scene = load(src, sets)?;
    let out = render(&scene, render_opts)?;
    write_image(path, &out.image)?;
    Ok(out)
}

/// The optional progress bar over the renders: one step per render, the current point as
/// its message.
pub(crate) struct Progress(Option<indicatif::ProgressBar>);

impl Progress {
    /// A bar of `renders` steps when `show` is set; otherwise nothing is drawn.
    pub(crate) fn new(show: bool, renders: u64) -> Progress {
        Progress(show.then(|| {
            let pb = indicatif::ProgressBar::new(renders);
            pb.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} renders {msg}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            // A reference render can take minutes: keep the clock moving between renders.
            pb.enable_steady_tick(std::time::Duration::from_millis(250));
            pb
        }))
    }

    /// Names the render under way.
    pub(crate) fn say(&self, msg: String) {
        if let Some(pb) = &self.0 {
            pb.set_message(msg);
        }
    }

    /// Counts one render done.
    pub(crate) fn step(&self) {
        if let Some(pb) = &self.0 {
            pb.inc(1);
        }
    }

    /// Removes the bar once every render is done.
    pub(crate) fn finish(&self) {
        if let Some(pb) = &self.0 {
            pb.finish_and_clear();
        }
    }
}
