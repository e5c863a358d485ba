//! `wavetrace bench`: traversal throughput of the packet, wide, interleaved, stream and hybrid kernels
//! on fixed ray sets (a scene's, or the issue-13 sets around a bare mesh), as a table or
//! JSON; optionally exports the rays for `benches/embree.py`.

use clap::{Args, ValueEnum};
use std::path::PathBuf;

use wavetrace::accel::order::Order;
use wavetrace::accel::packet::PacketConfig;
use wavetrace::scene::load;
use wavetrace::simd::LANES;
use wavetrace::tools::bench::{self, BenchOptions};
use wavetrace::tools::bench_mesh;
use wavetrace::{Error, Result};

use super::{at_least_one, say, scene_source, Switch};

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Scene file (TOML). Omitted: the embedded default scene.
    scene: Option<PathBuf>,
    /// Instead of a scene: a bare triangle mesh (OBJ), with the camera, shadow, bounce,
    /// random and bounce-shadow ray sets around it (√max-rays² camera rays).
    #[arg(long, value_name = "OBJ", conflicts_with_all = ["scene", "sets", "sphere"])]
    mesh: Option<PathBuf>,
    /// Instead of a scene: a generated displaced icosphere of 20·4^LEVEL triangles
    /// (8: 1,310,720), with the same ray sets as --mesh.
    #[arg(long, value_name = "LEVEL", conflicts_with_all = ["scene", "sets"], value_parser = clap::value_parser!(u32).range(0..=10))]
    sphere: Option<u32>,
    /// With --mesh or --sphere: most primitives per BVH leaf (1 to 64).
    #[arg(long, default_value_t = wavetrace::accel::MAX_LEAF, value_parser = clap::value_parser!(u32).range(1..=64))]
    leaf: u32,
    /// With --mesh or --sphere: the BVH build's quality (a scene sets `render.bvh`).
    #[arg(long, value_enum, default_value_t = Quality::High)]
    bvh: Quality,
    /// Write the triangles, the ray sets and the wide kernel's answers as NumPy files to
    /// DIR (for benches/embree.py); triangle-only scenes.
    #[arg(long, value_name = "DIR")]
    export_rays: Option<PathBuf>,
    /// Override a scene value by its dotted path (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Worker threads (default: all cores); at most 4 per CPU (a limit of at
    /// least 64 and at most 1024).
    #[arg(long, allow_negative_numbers = true, value_parser = super::thread_count)]
    threads: Option<usize>,
    /// Timed repetitions per set and kernel; the median is reported.
    #[arg(long, default_value_t = 5, value_parser = at_least_one::<usize>())]
    reps: usize,
    /// Most rays per set (larger sets keep every k-th ray).
    #[arg(long, default_value_t = 1 << 20, value_parser = at_least_one::<usize>())]
    max_rays: usize,
    /// Lanes per packet of the packet kernel: 4, 8 or 16.
    #[arg(long, value_enum, hide_possible_values = true, default_value_t = Lanes::of(LANES))]
    lanes: Lanes,
    /// Packet kernel: how bounce rays are ordered before packets are cut: keep, octant
    /// or morton (octant, then the origin's Morton code).
    #[arg(long, value_enum, hide_possible_values = true, default_value_t = PacketConfig::RENDER.bounce_order.into())]
    bounce_order: PacketOrder,
    /// Packet kernel: how shadow rays are ordered: keep, octant or morton.
    #[arg(long, value_enum, hide_possible_values = true, default_value_t = PacketConfig::RENDER.shadow_order.into())]
    shadow_order: PacketOrder,
    /// Packet kernel: trace packets that mix direction octants one ray at a time (on|off).
    #[arg(long, value_enum, hide_possible_values = true, default_value_t = Switch::of(PacketConfig::RENDER.split_mixed))]
    split_mixed: Switch,
    /// Hybrid kernel: a bounce or shadow queue whose probe packets' beams reach more than
    /// this many leaves per 100 rays goes on over the wide BVH, without packets.
    #[arg(long, default_value_t = bench::RENDER_MAX_LEAVES)]
    max_leaves: u32,
    /// Time by the process's CPU time, not the wall clock (for a shared, loaded machine).
    #[arg(long)]
    cpu_time: bool,
    /// The kernels to measure, comma separated: packet, wide, interleaved, stream, hybrid
    /// (default: all five; their answers are checked against the first one listed).
    #[arg(long, value_enum, value_delimiter = ',', hide_possible_values = true)]
    kernels: Vec<KernelName>,
    /// The ray sets to measure, comma separated, by the names the table prints (default:
    /// all of them).
    #[arg(long, value_delimiter = ',')]
    ray_sets: Vec<String>,
    /// Print JSON: {"bvh_build_seconds", "bvh_build_phases": {"ploc", "reinsertion", "leaf_collapse",
    /// "reorder", "wide_plan", "wide_fill", "wide_blocks", "rest"}, "primitives", "bytes_per_primitive", "threads", "renderer_kernel", "clock",
    /// "sets": [{"set", "kernel", "rays", "mrays_per_s"}]}.
    #[arg(long)]
    json: bool,
}

/// `--kernels`: one of the kernels `wavetrace bench` measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum KernelName {
    Packet,
    Wide,
    Interleaved,
    Stream,
    Hybrid,
}

impl KernelName {
    fn name(self) -> &'static str {
        bench::KERNELS[self as usize]
    }
}

/// `--bvh`: [`BvhQuality`](wavetrace::accel::BvhQuality) on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Quality {
    Low,
    Medium,
    High,
}

impl Quality {
    fn quality(self) -> wavetrace::accel::BvhQuality {
        match self {
            Quality::Low => wavetrace::accel::BvhQuality::Low,
            Quality::Medium => wavetrace::accel::BvhQuality::Medium,
            Quality::High => wavetrace::accel::BvhQuality::High,
        }
    }
}

/// `--lanes`: the packet widths the packet kernel is built for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Lanes {
    #[value(name = "4")]
    Four,
    #[value(name = "8")]
    Eight,
    #[value(name = "16")]
    Sixteen,
}

impl Lanes {
    /// Lanes per packet.
    pub fn count(self) -> usize {
        match self {
            Lanes::Four => 4,
            Lanes::Eight => 8,
            Lanes::Sixteen => 16,
        }
    }

    /// The choice of `n` lanes.
    ///
    /// # Panics
    /// If `n` is not 4, 8 or 16: only the renderer's own width is asked for, and it is
    /// one of those.
    pub fn of(n: usize) -> Lanes {
        match n {
            4 => Lanes::Four,
            8 => Lanes::Eight,
            16 => Lanes::Sixteen,
            _ => panic!("no packet kernel of {n} lanes"),
        }
    }
}

/// `--bounce-order`, `--shadow-order`: the command-line names of [`Order`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PacketOrder {
    Keep,
    Octant,
    Morton,
}

impl From<Order> for PacketOrder {
    fn from(o: Order) -> Self {
        match o {
            Order::Keep => PacketOrder::Keep,
            Order::Octant => PacketOrder::Octant,
            Order::Morton => PacketOrder::Morton,
        }
    }
}

impl From<PacketOrder> for Order {
    fn from(o: PacketOrder) -> Self {
        match o {
            PacketOrder::Keep => Order::Keep,
            PacketOrder::Octant => Order::Octant,
            PacketOrder::Morton => Order::Morton,
        }
    }
}

/// Runs the benchmark and prints the table or the JSON.
pub fn run(args: BenchArgs) -> Result<()> {
    let threads = args.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let packet = PacketConfig {
        bounce_order: args.bounce_order.into(),
        shadow_order: args.shadow_order.into(),
        split_mixed: args.split_mixed.is_on(),
    };
    let opts = BenchOptions {
        threads,
        reps: args.reps,
        max_rays: args.max_rays,
        lanes: args.lanes.count(),
        packet,
        max_leaves: args.max_leaves,
        cpu_time: args.cpu_time,
        kernels: args.kernels.iter().map(|k| k.name()).collect(),
    };
    opts.check()?;
    let side = (opts.max_rays as f64).sqrt() as usize;
    let (accel, sets) = if let Some(path) = &args.mesh {
        let accel = bench_mesh::mesh_accel(
            wavetrace::scene::mesh::load_obj(path).map_err(Error::input)?,
            args.leaf,
            args.bvh.quality(),
        );
        let sets = bench_mesh::mesh_ray_sets(&accel, side.max(1));
        (accel, sets)
    } else if let Some(levels) = args.sphere {
        let accel = bench_mesh::mesh_accel(bench_mesh::displaced_sphere(levels), args.leaf, args.bvh.quality());
        let sets = bench_mesh::mesh_ray_sets(&accel, side.max(1));
        (accel, sets)
    } else {
        let source = scene_source(args.scene.as_ref())?;
        let scene = load(&source, &args.sets)?;
        let sets = bench::ray_sets(&scene, opts.max_rays).into_iter().collect();
        (scene.accel, sets)
    };
    if let Some(unknown) = args.ray_sets.iter().find(|s| !sets.iter().any(|(name, _)| name == s)) {
        let names: Vec<_> = sets.iter().map(|(name, _)| *name).collect();
        return Err(Error::input(format!("--ray-sets {unknown}: expected one of {}", names.join(", "))));
    }
    let mut sets = sets;
    sets.retain(|(name, _)| args.ray_sets.is_empty() || args.ray_sets.iter().any(|s| s == name));
    if let Some(dir) = &args.export_rays {
        bench_mesh::export(dir, &accel, &sets)?;
    }
    let report = bench::run(&accel, &sets, &opts)?;
    if args.json {
        say(&serde_json::to_string(&report).map_err(|e| Error::Internal(e.to_string()))?);
    } else {
        say(report.table().trim_end());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_and_orders_round_trip() {
        for n in [4, 8, 16, LANES] {
            assert_eq!(Lanes::of(n).count(), n);
        }
        for o in [Order::Keep, Order::Octant, Order::Morton] {
            assert_eq!(Order::from(PacketOrder::from(o)), o);
            // The command-line name is the one Order prints.
            assert_eq!(PacketOrder::from(o).to_possible_value().unwrap().get_name(), o.to_string());
        }
    }
}
