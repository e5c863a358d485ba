//! What a sweep writes: the CSV, the JSON, the table it prints and the two plots.

use super::*;

/// `value` as pretty JSON with a leading `version` field, its own fields after in order.
pub(crate) fn versioned_json<T: Serialize>(version: u32, value: &T) -> Result<String> {
    #[derive(Serialize)]
    struct Doc<'a, T> {
        version: u32,
        #[serde(flatten)]
        result: &'a T,
    }
    // Serialized straight to text: going through serde_json::Value would sort the keys.
    serde_json::to_string_pretty(&Doc { version, result: value }).map_err(|e| Error::Internal(e.to_string()))
}

/// Quotes a CSV field when it holds a comma, a quote or a line break (RFC 4180).
pub(crate) fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

impl SweepResult {
    /// The CSV: a header, then one row per point: the param values, `mode`,
    /// `total_rays`, `rays_<kind>` for each ray kind, `seconds`, `rmse`, `rel_mse`,
    /// `psnr` (`inf` for an exact match) and `flip`.
    pub fn csv(&self) -> String {
        let kinds: Vec<String> =
            crate::stats::Stats::default().kinds().iter().map(|k| format!("rays_{}", k.0)).collect();
        let mut header: Vec<String> = self.keys.clone();
        header.extend(["mode".to_string(), "total_rays".to_string()]);
        header.extend(kinds);
        header.extend(["seconds", "rmse", "rel_mse", "psnr", "flip"].map(String::from));
        let mut out = header.iter().map(|h| csv_field(h)).collect::<Vec<_>>().join(",") + "\n";
        for p in &self.points {
            let mut row: Vec<String> = p.params.iter().map(|(_, v)| csv_field(v)).collect();
            row.push(p.mode.label().into());
            row.push(p.total_rays.to_string());
            row.extend(p.rays.iter().map(|(_, n)| n.to_string()));
            let m = &p.metrics;
            row.extend([p.seconds, m.rmse, m.rel_mse, m.psnr, m.flip].map(|v| v.to_string()));
            out += &(row.join(",") + "\n");
        }
        out
    }

    /// The text of `sweep.json`: `version`, then the fields of [`SweepResult`] in order
    /// (`files` left out). Maps keep their order: params as swept, ray kinds as in the
    /// stats. Non-finite numbers, such as the PSNR of an exact match, become `null`.
    pub fn json(&self) -> Result<String> {
        versioned_json(JSON_VERSION, self)
    }

    /// A text table of the points, for the terminal.
    pub fn table(&self) -> String {
        let mut out = String::new();
        for k in &self.keys {
            out += &format!("{k:>22} ");
        }
        out += &format!("{:>9} {:>13} {:>9} {:>10} {:>9}\n", "mode", "rays", "seconds", "rmse", "flip");
        for p in &self.points {
            for (_, v) in &p.params {
                out += &format!("{v:>22} ");
            }
            let front = if p.pareto_rays { " *" } else { "" };
            out += &format!(
                "{:>9} {:>13} {:>9.3} {:>10.6} {:>9.5}{front}\n",
                p.mode.label(),
                p.total_rays,
                p.seconds,
                p.metrics.rmse,
                p.metrics.flip
            );
        }
        out + "(* on the mode's Pareto front in rays and RMSE)"
    }

    /// Draws RMSE against `x` of each point, one series per mode, log-log.
    #[cfg(feature = "plot")]
    pub(super) fn plot(&self, path: &Path, x: impl Fn(&Point) -> f64, x_label: &str) -> Result<()> {
        let by_seconds = path.ends_with(SECONDS_PLOT);
        let labels = point_labels(&self.points);
        // Uniform and adaptive always, an empty one included, so uniform is blue and
        // adaptive orange in every plot; the extensions only when the sweep has them.
        let series: Vec<Series> = Mode::ALL
            .iter()
            .filter(|&&m| m <= Mode::Adaptive || self.points.iter().any(|p| p.mode == m))
            .map(|&mode| {
                let idx: Vec<usize> = (0..self.points.len()).filter(|&i| self.points[i].mode == mode).collect();
                let pts: Vec<&Point> = idx.iter().map(|&i| &self.points[i]).collect();
                Series {
                    name: mode.label().into(),
                    points: pts.iter().map(|p| (x(p), p.metrics.rmse)).collect(),
                    pareto: pts.iter().map(|p| if by_seconds { p.pareto_seconds } else { p.pareto_rays }).collect(),
                    labels: idx.iter().map(|&i| labels[i].clone()).collect(),
                }
            })
            .collect();
        let name = Path::new(&self.scene).file_stem().map_or(self.scene.clone(), |s| s.to_string_lossy().into_owned());
        let title = format!(
            "{name}: RMSE vs {} (filled and joined: each mode's Pareto front)",
            if by_seconds { "seconds" } else { "rays" }
        );
        let (x, y) = (Axis { label: x_label, log: true }, Axis { label: "RMSE (linear)", log: true });
        scatter_plot(path, &title, x, y, &series)
    }
}

/// Plot labels: a point's values with the last segment of each key (`samples=64
/// eps=0.01`). Points whose renders came out the same (same mode, rays of every kind and
/// error: a setting their mode ignores differs) share one label of the values they have
/// in common, with their count: `samples=4 (×3)`. A `*.mode` value that names the point's
/// series is left out, as the colour says it.
#[cfg(feature = "plot")]
fn point_labels(points: &[Point]) -> Vec<String> {
    let same = |a: &Point, b: &Point| {
        a.mode == b.mode && a.rays == b.rays && a.metrics.rmse.to_bits() == b.metrics.rmse.to_bits()
    };
    points
        .iter()
        .map(|p| {
            let group: Vec<&Point> = points.iter().filter(|q| same(p, q)).collect();
            let text = p
                .params
                .iter()
                .filter(|(k, v)| !(k.ends_with(".mode") && v == p.mode.label()))
                .filter(|(k, v)| group.iter().all(|q| q.params.iter().any(|(qk, qv)| qk == k && qv == v)))
                .map(|(k, v)| format!("{}={v}", k.rsplit('.').next().unwrap_or(k)))
                .collect::<Vec<_>>()
                .join(" ");
            if group.len() > 1 {
                format!("{text} (×{})", group.len())
            } else {
                text
            }
        })
        .collect()
}
