//! Roofline benchmark: what bounds DFSPH's pair passes on this machine. Measures, at the
//! real scenes' sizes (2,500 particles, whose pair data fits a core's L2; 10,200, the game
//! pool; 20,000, the salva scene), on 1 and 2 threads (rayon, over the crate's chunks of 256
//! particles):
//!
//! 1. **stream**: a sum of `f32`s over an array as large as a rate pass's streamed pair data
//!    (16 bytes a pair: the neighbour index and the 12-byte packed gradient), in GB/s;
//! 2. **gather**: per pair, the neighbour index then the neighbour's 16-byte value at that
//!    index (the passes' access pattern), over neighbour lists built by the crate's own search
//!    (`NeighborGrid`, `NeighborLists`), in the crate's cell order and with the particles
//!    shuffled (the worst case: every gather a random address);
//! 3. **rate** and **push**: DFSPH's two passes of a density iteration, `Σ_j (v_i − v_j)·∇W_ij`
//!    (then the density solve's per-particle finish) and `Σ_j (π_i + π_j) ∇W_ij` (then the
//!    velocity update and the summed pressure), written as the crate writes them
//!    (`solver::dfsph::rate_pass`, `apply_pressure`, `pair_sum` with four accumulators, the
//!    gradients packed 12 bytes a pair and loaded 16 bytes wide as `solver::pairs::
//!    PackedGradients` does, compiled for AVX-512 or AVX2 as `par::wide` does). These are
//!    crate-private, so this file holds a copy of their pair loops (without the walls'
//!    per-particle terms and the hydrostatic walls' pair weights); and the rate pass reading
//!    16-byte gradients (`Vec3A`, as the crate stored them before packing: 20 bytes a pair);
//! 4. the same two passes **in L1**: the first 32 particles of a chunk in the block's middle
//!    (their pairs, about 14 KB, and the values they gather fit a 48 KB L1), replayed by
//!    each thread for as many pairs in all as a whole pass: the passes' cost without memory
//!    traffic, what the arithmetic, the loads and the dependent add chains cost (sorted lists
//!    only);
//! 5. the two passes, in memory and in L1, with each pair's gradient as a 4-byte **factor** on
//!    the separation, `∇W_ij = (x_i − x_j)·c_ij`, the neighbour's position gathered (16 bytes,
//!    `Vec3A`) and the separation recomputed in the pass: 8 bytes streamed a pair (index and
//!    factor) instead of 16, a few more instructions. The gradient is formed as `r·c` with the
//!    same `r` and `c`, so the factor passes give the packed passes' results bit for bit
//!    (checked pair by pair when the data is built, and on both passes' outputs before
//!    timing). They read the position unchecked (every index is checked once against the
//!    positions when built) and the factor as the packed passes read the gradient, so they
//!    pay as many checks a pair as the packed passes (two, or none with `--unchecked`).
//!
//! The passes' copies read each pair's gradient (or factor) and the neighbour's velocity or
//! pressure value with a bounds check, as the crate did when the bench was written; with
//! `--unchecked` without, as the crate's passes now do (each index checked once against the
//! particle count when the lists are built).
//!
//! ```text
//! cargo bench --bench roofline                     # all sizes, 1 and 2 threads
//! cargo bench --bench roofline -- --quick          # fewer rounds
//! cargo bench --bench roofline -- --particles 20000 --threads 1 --rounds 30
//! cargo bench --bench roofline -- --only rate --particles 20000 --threads 1 --passes 20
//!                                                  # one kernel, fixed passes, no table
//!                                                  # (for `valgrind --tool=callgrind`)
//! cargo bench --bench roofline -- --unchecked      # the passes without bounds checks
//! ```
//!
//! The particles are a cubic lattice of spacing `s` jittered by up to ±0.15 `s` per axis (a
//! fixed seed), the support radius `h = 2 s` as in the `water` and `game_water` presets:
//! 24.9, 26.5 and 27.0 neighbours per particle on average at the three sizes, the block's
//! surface included (the salva scene's example prints 27.4). The velocities, pressure values
//! and gradients are synthetic but finite; the passes' cost does not depend on their values.
//!
//! Timing: every kernel runs once per round, round after round (interleaved, so a change of
//! the machine's speed reaches all of them alike); each sample is as many passes as take at
//! least 4 ms, timed in CPU time of the pool's threads (a preempted thread does not count).
//! The first table gives each kernel's fastest sample and median over the rounds in CPU ns
//! per pair; the second the medians of ratios taken within a round (in-memory pass ÷ in-L1
//! pass, 16-byte ÷ packed gradients, stream ÷ pass, factor ÷ packed), which hold when the
//! machine's speed changes between rounds. The first line gives the core's clock while
//! running, from a chain of dependent multiplications.

use rapier_sph::math::{Real, Vector};
use rapier_sph::neighbors::{NeighborGrid, NeighborLists};
use rapier_sph::rapier3d::glamx::Vec3A;
use rayon::prelude::*;
use std::hint::black_box;
use std::time::Instant;

/// Particles per work item, as the crate's `par::CHUNK`.
const CHUNK: usize = 256;
/// Accumulators of the solves' pair sums, as the crate's `solver::dfsph::ACC`.
const ACC: usize = 4;
/// Jitter of the lattice, in spacings (each axis, uniform in ±JITTER).
const JITTER: Real = 0.15;
/// Particles replayed by the in-L1 passes.
const L1_PARTICLES: usize = 32;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let value = |flag: &str| args.windows(2).find(|w| w[0] == flag).map(|w| w[1].clone());
    let list = |flag: &str, default: &[usize]| -> Vec<usize> {
        value(flag).map_or(default.to_vec(), |v| {
            v.split(',')
                .map(|x| x.parse().expect("a list of integers"))
                .collect()
        })
    };
    let quick = args.iter().any(|a| a == "--quick");
    let unchecked = args.iter().any(|a| a == "--unchecked");
    let sizes = list("--particles", &[2_500, 10_200, 20_000]);
    let threads = list("--threads", &[1, 2]);
    let rounds: usize = value("--rounds").map_or(if quick { 7 } else { 21 }, |v| {
        v.parse().expect("--rounds takes an integer")
    });
    if let Some(kernel) = value("--only") {
        let passes: usize = value("--passes").map_or(10, |v| v.parse().expect("an integer"));
        let shuffled = args.iter().any(|a| a == "--shuffled");
        only(&kernel, sizes[0], threads[0], passes, shuffled, unchecked);
        return;
    }
    println!(
        "roofline of the pair passes: {} ({}), {}",
        std::env::consts::ARCH,
        isa_name(),
        cpu_name()
    );
    println!(
        "the passes read each pair's gradient (or factor) and the neighbour's value {}",
        if unchecked {
            "unchecked, as the crate's passes do (--unchecked)"
        } else {
            "with a bounds check each"
        }
    );
    if let Some(ghz) = clock_ghz() {
        println!(
            "core clock while running: {ghz:.2} GHz (a chain of dependent integer multiplications, 3 cycles each; fastest of 1,000 samples of 0.1 ms)"
        );
    }
    println!(
        "CPU ns per pair (the CPU time of the pool's threads, summed, so preemption does not count), \
         fastest sample / median of {rounds} interleaved rounds; stream: GB per CPU second; \
         last column: the wall ns per pair of a rate and a push pass, fastest samples"
    );
    println!();
    println!(
        "| particles | neighbours | pair data (MB) | order | threads | stream (GB/s) | gather | rate | rate, 16-byte gradients | push | rate in L1 | push in L1 | rate, factor | push, factor | rate in L1, factor | push in L1, factor | rate + push, wall |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut ratios = Vec::new();
    for &n in &sizes {
        for shuffled in [false, true] {
            let mut data = Data::new(n, shuffled);
            data.unchecked = unchecked;
            let pools: Vec<_> = threads
                .iter()
                .map(|&t| {
                    rayon::ThreadPoolBuilder::new()
                        .num_threads(t)
                        .build()
                        .unwrap()
                })
                .collect();
            let mut state = State::new(&data);
            check_factor_passes::<false>(&data, &mut state);
            check_factor_passes::<true>(&data, &mut state);
            // wall[thread case][kernel], cpu[..][..]: ns per pair.
            let mut wall = vec![vec![Vec::new(); Kernel::ALL.len()]; threads.len()];
            let mut cpu = wall.clone();
            for round in 0..=rounds {
                for (p, pool) in pools.iter().enumerate() {
                    for (k, &kernel) in Kernel::ALL.iter().enumerate() {
                        // In L1 is measured on the sorted lists only (shuffled, the values
                        // the replayed particles gather are spread over the whole array).
                        if shuffled
                            && matches!(
                                kernel,
                                Kernel::RateL1
                                    | Kernel::PushL1
                                    | Kernel::RateFactorL1
                                    | Kernel::PushFactorL1
                            )
                        {
                            continue;
                        }
                        let (w, c) = time(pool, kernel, &data, &mut state);
                        // Round 0 warms up (pages touched, caches and branch predictors).
                        if round > 0 {
                            wall[p][k].push(w);
                            cpu[p][k].push(c);
                        }
                    }
                }
            }
            for (p, &t) in threads.iter().enumerate() {
                ratios.push(Ratios::new(data.n, shuffled, t, &cpu[p]));
            }
            for (p, &t) in threads.iter().enumerate() {
                let s: Vec<(f64, f64)> = cpu[p].iter_mut().map(|v| min_median(v)).collect();
                let w: Vec<(f64, f64)> = wall[p].iter_mut().map(|v| min_median(v)).collect();
                let pairs = data.pairs as f64;
                let cell = |k: Kernel| {
                    let (lo, med) = s[k as usize];
                    if lo.is_nan() {
                        return "–".to_string();
                    }
                    format!("{lo:.2} / {med:.2}")
                };
                let (slo, smed) = s[Kernel::Stream as usize];
                println!(
                    "| {} | {:.1} | {:.1} | {} | {} | {:.0} / {:.0} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.2} |",
                    n_label(data.n),
                    pairs / data.n as f64,
                    pairs * 16.0 / 1e6,
                    if shuffled { "shuffled" } else { "sorted" },
                    t,
                    16.0 / slo,
                    16.0 / smed,
                    cell(Kernel::Gather),
                    cell(Kernel::Rate),
                    cell(Kernel::Rate16),
                    cell(Kernel::Push),
                    cell(Kernel::RateL1),
                    cell(Kernel::PushL1),
                    cell(Kernel::RateFactor),
                    cell(Kernel::PushFactor),
                    cell(Kernel::RateFactorL1),
                    cell(Kernel::PushFactorL1),
                    w[Kernel::Rate as usize].0 + w[Kernel::Push as usize].0,
                );
            }
            black_box(state.checksum());
        }
    }
    println!();
    println!(
        "ratios of CPU times taken in the same round (a change of the machine's speed between rounds \
         cancels), median [25th–75th percentile] over the rounds; stream ÷ pass: the fraction of the \
         stream's bandwidth a pass streams its 16 bytes a pair at; factor: the gradient as a 4-byte \
         factor on the separation recomputed from the gathered positions"
    );
    println!();
    println!(
        "| particles | order | threads | rate ÷ rate in L1 | push ÷ push in L1 | rate with 16-byte gradients ÷ rate | stream ÷ rate | stream ÷ push | rate, factor ÷ rate | push, factor ÷ push | in L1: rate, factor ÷ rate | in L1: push, factor ÷ push |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in &ratios {
        println!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            n_label(r.n),
            if r.shuffled { "shuffled" } else { "sorted" },
            r.threads,
            r.rate_l1,
            r.push_l1,
            r.rate16,
            r.stream_rate,
            r.stream_push,
            r.rate_factor,
            r.push_factor,
            r.rate_factor_l1,
            r.push_factor_l1
        );
    }
}

/// Per-round ratios of one row (see `main`'s second table), formatted.
struct Ratios {
    n: usize,
    shuffled: bool,
    threads: usize,
    rate_l1: String,
    push_l1: String,
    rate16: String,
    stream_rate: String,
    stream_push: String,
    rate_factor: String,
    push_factor: String,
    rate_factor_l1: String,
    push_factor_l1: String,
}

impl Ratios {
    /// From `cpu[kernel][round]` (ns per pair).
    fn new(n: usize, shuffled: bool, threads: usize, cpu: &[Vec<f64>]) -> Ratios {
        let ratio = |a: Kernel, b: Kernel| {
            let (a, b) = (&cpu[a as usize], &cpu[b as usize]);
            if a.is_empty() || a.len() != b.len() {
                return "–".to_string();
            }
            let mut r: Vec<f64> = a.iter().zip(b).map(|(x, y)| x / y).collect();
            r.sort_by(f64::total_cmp);
            let q = |f: f64| r[((r.len() - 1) as f64 * f).round() as usize];
            format!("{:.2} [{:.2}–{:.2}]", q(0.5), q(0.25), q(0.75))
        };
        Ratios {
            n,
            shuffled,
            threads,
            rate_l1: ratio(Kernel::Rate, Kernel::RateL1),
            push_l1: ratio(Kernel::Push, Kernel::PushL1),
            rate16: ratio(Kernel::Rate16, Kernel::Rate),
            stream_rate: ratio(Kernel::Stream, Kernel::Rate),
            stream_push: ratio(Kernel::Stream, Kernel::Push),
            rate_factor: ratio(Kernel::RateFactor, Kernel::Rate),
            push_factor: ratio(Kernel::PushFactor, Kernel::Push),
            rate_factor_l1: ratio(Kernel::RateFactorL1, Kernel::RateL1),
            push_factor_l1: ratio(Kernel::PushFactorL1, Kernel::PushL1),
        }
    }
}

/// `--only KERNEL`: `passes` passes of one kernel and nothing timed (for instruction counts:
/// run it with 0 and with N passes under `valgrind --tool=callgrind` and divide the
/// difference of the counts by N times the pairs it prints).
fn only(kernel: &str, n: usize, threads: usize, passes: usize, shuffled: bool, unchecked: bool) {
    let kernel = *Kernel::ALL
        .iter()
        .find(|k| k.name() == kernel)
        .unwrap_or_else(|| panic!("--only takes one of {:?}", Kernel::ALL.map(|k| k.name())));
    let mut data = Data::new(n, shuffled);
    data.unchecked = unchecked;
    let mut state = State::new(&data);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        for _ in 0..passes {
            run(kernel, &data, &mut state);
        }
    });
    println!(
        "{} particles, {} pairs ({:.2} per particle), {} passes of {}, checksum {}",
        data.n,
        data.pairs,
        data.pairs as f64 / data.n as f64,
        passes,
        kernel.name(),
        state.checksum()
    );
}

fn n_label(n: usize) -> String {
    let s = n.to_string();
    if n < 10_000 {
        return s;
    }
    let (a, b) = s.split_at(s.len() - 3);
    format!("{a},{b}")
}

/// The fastest value and the median of `v` (sorted in place).
fn min_median(v: &mut [f64]) -> (f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    v.sort_by(f64::total_cmp);
    (v[0], v[v.len() / 2])
}

#[derive(Copy, Clone, PartialEq, Eq, Debug)]
enum Kernel {
    Stream,
    Gather,
    Rate,
    Rate16,
    Push,
    RateL1,
    PushL1,
    RateFactor,
    PushFactor,
    RateFactorL1,
    PushFactorL1,
}

impl Kernel {
    const ALL: [Kernel; 11] = [
        Kernel::Stream,
        Kernel::Gather,
        Kernel::Rate,
        Kernel::Rate16,
        Kernel::Push,
        Kernel::RateL1,
        Kernel::PushL1,
        Kernel::RateFactor,
        Kernel::PushFactor,
        Kernel::RateFactorL1,
        Kernel::PushFactorL1,
    ];

    fn name(self) -> &'static str {
        match self {
            Kernel::Stream => "stream",
            Kernel::Gather => "gather",
            Kernel::Rate => "rate",
            Kernel::Rate16 => "rate-16",
            Kernel::Push => "push",
            Kernel::RateL1 => "rate-l1",
            Kernel::PushL1 => "push-l1",
            Kernel::RateFactor => "rate-factor",
            Kernel::PushFactor => "push-factor",
            Kernel::RateFactorL1 => "rate-factor-l1",
            Kernel::PushFactorL1 => "push-factor-l1",
        }
    }
}

/// One sample of `kernel` on `pool`: as many passes as take at least 4 ms of wall time, in
/// wall ns per pair and CPU ns per pair (the CPU time of the pool's threads, summed).
fn time(pool: &rayon::ThreadPool, kernel: Kernel, data: &Data, state: &mut State) -> (f64, f64) {
    let c0 = pool_cpu_seconds(pool);
    let (t, passes) = pool.install(|| {
        let mut passes = 0usize;
        let t0 = Instant::now();
        loop {
            run(kernel, data, state);
            passes += 1;
            let t = t0.elapsed().as_secs_f64();
            if t >= 4e-3 {
                return (t, passes);
            }
        }
    });
    let cpu = pool_cpu_seconds(pool) - c0;
    let per_pair = 1e9 / (passes * data.pairs) as f64;
    (t * per_pair, cpu * per_pair)
}

/// The CPU seconds of `pool`'s threads, summed (each thread's own clock, so neither other
/// processes nor this process's other pools count).
fn pool_cpu_seconds(pool: &rayon::ThreadPool) -> f64 {
    pool.broadcast(|_| thread_cpu_seconds()).iter().sum()
}

/// The calling thread's CPU seconds, from `clock_gettime(CLOCK_THREAD_CPUTIME_ID)` (Linux;
/// elsewhere the wall clock since the first call, and the CPU figures are wall figures).
fn thread_cpu_seconds() -> f64 {
    #[cfg(target_os = "linux")]
    {
        #[repr(C)]
        struct Timespec {
            sec: i64,
            nsec: i64,
        }
        unsafe extern "C" {
            fn clock_gettime(clock: i32, ts: *mut Timespec) -> i32;
        }
        const CLOCK_THREAD_CPUTIME_ID: i32 = 3;
        let mut ts = Timespec { sec: 0, nsec: 0 };
        // SAFETY: `ts` is a valid `struct timespec` (64-bit Linux layout) for the call.
        if unsafe { clock_gettime(CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0 {
            return ts.sec as f64 + ts.nsec as f64 * 1e-9;
        }
        0.0
    }
    #[cfg(not(target_os = "linux"))]
    {
        static START: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
        START.get_or_init(Instant::now).elapsed().as_secs_f64()
    }
}

/// One pass of `kernel` over every pair (the in-L1 kernels: over as many pairs, replayed),
/// the passes' reads checked or, with `data.unchecked`, not.
fn run(kernel: Kernel, data: &Data, state: &mut State) {
    if data.unchecked {
        run_as::<true>(kernel, data, state)
    } else {
        run_as::<false>(kernel, data, state)
    }
}

/// [`run`], the passes' reads unchecked if `U`.
fn run_as<const U: bool>(kernel: Kernel, data: &Data, state: &mut State) {
    match kernel {
        Kernel::Stream => state.sink = stream(&data.stream),
        Kernel::Gather => state.sink = gather(data, &state.velocities),
        Kernel::Rate => rate::<PACKED, U>(data, state),
        Kernel::Rate16 => rate::<WIDE16, U>(data, state),
        Kernel::Push => push::<PACKED, U>(data, state),
        Kernel::RateL1 => state.sink = in_l1::<PACKED, U>(data, state, false),
        Kernel::PushL1 => state.sink = in_l1::<PACKED, U>(data, state, true),
        Kernel::RateFactor => rate::<FACTOR, U>(data, state),
        Kernel::PushFactor => push::<FACTOR, U>(data, state),
        Kernel::RateFactorL1 => state.sink = in_l1::<FACTOR, U>(data, state, false),
        Kernel::PushFactorL1 => state.sink = in_l1::<FACTOR, U>(data, state, true),
    }
}

/// The neighbour lists and pair gradients of one particle block, laid out as the crate lays
/// them out: per chunk of [`CHUNK`] particles, offsets, indices and packed gradients.
struct Data {
    n: usize,
    pairs: usize,
    chunks: Vec<Chunk>,
    /// As many bytes as a rate pass streams (16 a pair), for the stream kernel.
    stream: Vec<f32>,
    /// Pairs of the first [`L1_PARTICLES`] particles of the middle chunk (the in-L1 kernels'
    /// unit of work).
    l1_pairs: usize,
    /// The particles' positions, 16 bytes each, for the factor passes' separations.
    positions: Vec<Vec3A>,
    /// The passes read the pair's slot and the neighbour's value unchecked (`--unchecked`).
    unchecked: bool,
}

/// A chunk's lists (`offsets`: one more than its particles) and gradients (`3·pairs + 1`
/// floats, `x, y, z` packed, as `solver::pairs::PackedGradients`; and 16 bytes wide).
struct Chunk {
    offsets: Vec<u32>,
    indices: Vec<u32>,
    grad: Vec<Real>,
    /// The same gradients 16 bytes each (as the crate stored them before packing).
    grad16: Vec<Vec3A>,
    /// The same gradients as factors on the separation, `∇W_ij = (x_i − x_j)·c_ij`.
    factor: Vec<Real>,
}

impl Data {
    /// A jittered lattice of about `n` particles (spacing 1, `h` = 2), sorted and searched by
    /// the crate's own neighbour search; with `shuffled`, the particles relabelled in a random
    /// order afterwards (the lists then point anywhere).
    fn new(n: usize, shuffled: bool) -> Data {
        let side = (n as f64).cbrt();
        let (nx, ny) = (side.round() as usize, side.round() as usize);
        let nz = n.div_ceil(nx * ny);
        let mut rng = SplitMix(0x0005_eed0_f1a7_71ce);
        let mut positions = Vec::with_capacity(n);
        'fill: for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    if positions.len() == n {
                        break 'fill;
                    }
                    let mut j = || JITTER * (2.0 * rng.unit() - 1.0);
                    positions.push(Vector::new(
                        x as Real + j(),
                        y as Real + j(),
                        z as Real + j(),
                    ));
                }
            }
        }
        let h: Real = 2.0;
        let mut grid = NeighborGrid::default();
        grid.sort(&positions, h);
        let sorted: Vec<Vector> = grid
            .permutation()
            .iter()
            .map(|&(_, i)| positions[i as usize])
            .collect();
        grid.build_cells();
        let mut lists = NeighborLists::default();
        lists.build(&grid, &sorted, h);
        // order[t]: the sorted particle that particle t is; inverse[sorted] = t.
        let mut order: Vec<u32> = (0..n as u32).collect();
        if shuffled {
            for k in (1..n).rev() {
                order.swap(k, (rng.next() % (k as u64 + 1)) as usize);
            }
        }
        let mut inverse = vec![0u32; n];
        for (t, &o) in order.iter().enumerate() {
            inverse[o as usize] = t as u32;
        }
        let position = |t: usize| sorted[order[t] as usize];
        let mut chunks = Vec::new();
        let mut pairs = 0;
        for c in 0..n.div_ceil(CHUNK) {
            let (mut offsets, mut indices, mut grad, mut grad16, mut factor) =
                (vec![0u32], Vec::new(), Vec::new(), Vec::new(), Vec::new());
            for &o in &order[c * CHUNK..((c + 1) * CHUNK).min(n)] {
                let xi = sorted[o as usize];
                for &j in lists.of(o as usize) {
                    let j = inverse[j as usize];
                    indices.push(j);
                    // A cubic-spline-like slope: finite, the right sign, smooth.
                    let r = xi - position(j as usize);
                    let d = r.length().max(1e-6);
                    let q = 1.0 - d / h;
                    let c = -q * q / d;
                    let g = r * c;
                    grad.extend([g.x, g.y, g.z]);
                    grad16.push(Vec3A::from(g));
                    factor.push(c);
                }
                offsets.push(indices.len() as u32);
            }
            grad.push(0.0);
            pairs += indices.len();
            chunks.push(Chunk {
                offsets,
                indices,
                grad,
                grad16,
                factor,
            });
        }
        let middle = &chunks[chunks.len() / 2];
        let l1_pairs = middle.offsets[L1_PARTICLES.min(middle.offsets.len() - 1)] as usize;
        let positions: Vec<Vec3A> = (0..n).map(|t| Vec3A::from(position(t))).collect();
        // The factor passes read positions unchecked: every index must be below `n`.
        assert!(
            chunks
                .iter()
                .flat_map(|c| &c.indices)
                .all(|&j| (j as usize) < n),
            "a neighbour index beyond the particles"
        );
        let data = Data {
            n,
            pairs,
            chunks,
            stream: (0..4 * pairs).map(|k| (k % 7) as f32).collect(),
            l1_pairs,
            positions,
            unchecked: false,
        };
        data.check_factor_gradients();
        data
    }

    /// Particle `i`'s pairs `s..e` of chunk `c` as factors (see [`FactorSlice`]).
    #[inline(always)]
    fn factors(&self, c: usize, i: usize, s: usize, e: usize) -> FactorSlice<'_> {
        FactorSlice {
            c: &self.chunks[c].factor[s..e],
            xi: self.positions[i],
            positions: &self.positions,
        }
    }

    /// Every pair's gradient recomputed from its factor and the positions has the stored
    /// gradient's bits (the factor passes compute what the packed ones do).
    fn check_factor_gradients(&self) {
        for (c, chunk) in self.chunks.iter().enumerate() {
            for k in 0..chunk.offsets.len() - 1 {
                let i = c * CHUNK + k;
                let (s, e) = (chunk.offsets[k] as usize, chunk.offsets[k + 1] as usize);
                let f = self.factors(c, i, s, e);
                let g = GradientSlice::new(&chunk.grad, s, e);
                for t in 0..e - s {
                    let j = chunk.indices[s + t] as usize;
                    let (a, b) = (f.at(t, j, false), g.at(t));
                    assert!(
                        a.x.to_bits() == b.x.to_bits()
                            && a.y.to_bits() == b.y.to_bits()
                            && a.z.to_bits() == b.z.to_bits(),
                        "pair {t} of particle {i}: {a} from the factor, {b} stored"
                    );
                }
            }
        }
    }
}

/// The passes' per-particle arrays.
struct State {
    velocities: Vec<Vec3A>,
    densities: Vec<Real>,
    alpha: Vec<Real>,
    pi: Vec<Real>,
    rates: Vec<Real>,
    warm: Vec<Real>,
    partials: Vec<(f64, Real)>,
    sink: f64,
}

impl State {
    fn new(data: &Data) -> State {
        let n = data.n;
        let mut rng = SplitMix(7);
        let mut r = move || rng.unit() - 0.5;
        State {
            velocities: (0..n).map(|_| Vec3A::new(r(), r(), r())).collect(),
            densities: (0..n).map(|_| 1000.0 + r()).collect(),
            alpha: (0..n).map(|_| 1e-3 * (1.0 + r())).collect(),
            pi: (0..n).map(|_| r().max(0.0)).collect(),
            rates: vec![0.0; n],
            warm: vec![0.0; n],
            partials: vec![(0.0, 0.0); n.div_ceil(CHUNK)],
            sink: 0.0,
        }
    }

    /// Something of every array the passes write, so none is optimised away.
    fn checksum(&self) -> f64 {
        self.sink
            + self.partials.iter().map(|p| p.0).sum::<f64>()
            + self.warm.iter().map(|&w| w as f64).sum::<f64>()
            + self
                .velocities
                .iter()
                .map(|v| (v.x + v.y + v.z) as f64)
                .sum::<f64>()
    }
}

/// A sum of every float of `a` in parallel (64 lanes: four independent 16-wide vector
/// add chains, so the sum is not bound by the add's latency).
fn stream(a: &[f32]) -> f64 {
    a.par_chunks(CHUNK * 64)
        .map(|c| {
            wide(
                #[inline(always)]
                || {
                    let mut acc = [0.0f32; 64];
                    let mut it = c.chunks_exact(64);
                    for b in &mut it {
                        for l in 0..64 {
                            acc[l] += b[l];
                        }
                    }
                    acc.iter().sum::<f32>() + it.remainder().iter().sum::<f32>()
                },
            ) as f64
        })
        .sum()
}

/// Per pair, the neighbour index then the neighbour's 16-byte value: a sum of the gathered
/// values in four accumulators (the passes' `pair_sum` without the gradients).
fn gather(data: &Data, values: &[Vec3A]) -> f64 {
    data.chunks
        .par_iter()
        .map(|chunk| {
            wide(
                #[inline(always)]
                || {
                    let mut acc = [Vec3A::ZERO; ACC];
                    let full = chunk.indices.len() / ACC * ACC;
                    for j in chunk.indices[..full].chunks_exact(ACC) {
                        for l in 0..ACC {
                            acc[l] += values[j[l] as usize];
                        }
                    }
                    for &j in &chunk.indices[full..] {
                        acc[0] += values[j as usize];
                    }
                    let s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
                    (s.x + s.y + s.z) as f64
                },
            )
        })
        .sum()
}

/// Some consecutive packed gradients (see `solver::pairs::GradientSlice`).
#[derive(Copy, Clone)]
struct GradientSlice<'a> {
    data: &'a [Real],
    len: usize,
}

impl<'a> GradientSlice<'a> {
    #[inline(always)]
    fn new(grad: &'a [Real], s: usize, e: usize) -> Self {
        GradientSlice {
            data: &grad[3 * s..3 * e + 1],
            len: e - s,
        }
    }

    /// Gradient `t` as one unaligned 16-byte load (its `w` lane is not part of it).
    #[inline(always)]
    fn at(&self, t: usize) -> Vec3A {
        assert!(t < self.len);
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::_mm_loadu_ps;
            // SAFETY: `data` holds `3·len + 1` floats and `t < len`, so floats `3t..3t + 4`
            // are inside it; SSE is part of every x86-64 CPU.
            Vec3A::from(unsafe { _mm_loadu_ps(self.data.as_ptr().add(3 * t)) })
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let d = &self.data[3 * t..3 * t + 3];
            Vec3A::new(d[0], d[1], d[2])
        }
    }

    /// [`Self::at`] without the check (the crate's `GradientSlice::at_unchecked`).
    ///
    /// # Safety
    /// `t < self.len`.
    #[inline(always)]
    unsafe fn at_unchecked(&self, t: usize) -> Vec3A {
        debug_assert!(t < self.len);
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::_mm_loadu_ps;
            // SAFETY: as in `at`, with `t < len` from the caller.
            Vec3A::from(unsafe { _mm_loadu_ps(self.data.as_ptr().add(3 * t)) })
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            // SAFETY: as above, floats `3t..3t + 3` are inside `data`.
            let d = unsafe { self.data.get_unchecked(3 * t..3 * t + 3) };
            Vec3A::new(d[0], d[1], d[2])
        }
    }
}

/// `a[j]`, checked unless `unchecked` (a constant where the passes call it, so each
/// instantiation has one of the two).
///
/// # Safety
/// With `unchecked`, `j < a.len()`.
#[inline(always)]
unsafe fn get<T: Copy>(a: &[T], j: usize, unchecked: bool) -> T {
    if unchecked {
        debug_assert!(j < a.len());
        // SAFETY: the caller's.
        unsafe { *a.get_unchecked(j) }
    } else {
        a[j]
    }
}

/// Where a pass gets pair `t`'s gradient from (`j`: the pair's neighbour): the packed
/// gradients, 16-byte ones, or a factor on the separation recomputed from the positions;
/// `unchecked`: pair `t`'s slot read without a bounds check (the caller's `t < len()`).
trait PairValues {
    fn len(&self) -> usize;
    fn at(&self, t: usize, j: usize, unchecked: bool) -> Vec3A;
}

impl PairValues for GradientSlice<'_> {
    #[inline(always)]
    fn len(&self) -> usize {
        self.len
    }
    #[inline(always)]
    fn at(&self, t: usize, _: usize, unchecked: bool) -> Vec3A {
        if unchecked {
            // SAFETY: `pair_sum` reads `t < len` only.
            unsafe { GradientSlice::at_unchecked(self, t) }
        } else {
            GradientSlice::at(self, t)
        }
    }
}

impl PairValues for &[Vec3A] {
    #[inline(always)]
    fn len(&self) -> usize {
        <[Vec3A]>::len(self)
    }
    #[inline(always)]
    fn at(&self, t: usize, _: usize, _: bool) -> Vec3A {
        self[t]
    }
}

/// A particle's pair gradients as 4-byte factors on the separation: `∇W_ij = (x_i − x_j)·c_ij`,
/// the neighbour's position gathered (16 bytes, `Vec3A`) and the separation recomputed in the
/// pass. The same bits as the stored gradient when that was formed as `r·c` with the same `r`
/// and `c` (checked by `Data::check_factor_gradients` pair by pair and
/// by [`check_factor_passes`] on the passes' results).
#[derive(Copy, Clone)]
struct FactorSlice<'a> {
    c: &'a [Real],
    xi: Vec3A,
    positions: &'a [Vec3A],
}

impl PairValues for FactorSlice<'_> {
    #[inline(always)]
    fn len(&self) -> usize {
        self.c.len()
    }
    /// The factor checked as the packed gradient's slot is ([`GradientSlice::at`]), unless
    /// `unchecked`; the position always unchecked: [`Data::new`] asserts once that every
    /// index is below the number of positions (as the crate's passes assert once for the
    /// arrays they gather from), so the factor loop pays as many checks per pair as the
    /// packed one (the factor's slot and the neighbour's velocity or pressure value, or none).
    #[inline(always)]
    fn at(&self, t: usize, j: usize, unchecked: bool) -> Vec3A {
        // SAFETY: every neighbour index is below `positions.len()` (asserted in `Data::new`);
        // with `unchecked`, `pair_sum` reads `t < len` only.
        let (xj, c) = unsafe { (get(self.positions, j, true), get(self.c, t, unchecked)) };
        (self.xi - xj) * c
    }
}

/// `Σ_t term(nb[t], g[t])`, pair `t` into accumulator `t % ACC`, summed as `(a0 + a1) + (a2 +
/// a3)` (the crate's `solver::dfsph::pair_sum`).
#[inline(always)]
fn pair_sum(
    nb: &[u32],
    g: impl PairValues,
    unchecked: bool,
    term: impl Fn(usize, Vec3A) -> Vec3A,
) -> Vec3A {
    assert_eq!(g.len(), nb.len(), "one value per pair");
    let mut acc = [Vec3A::ZERO; ACC];
    let full = nb.len() / ACC * ACC;
    for (b, j) in nb[..full].chunks_exact(ACC).enumerate() {
        for l in 0..ACC {
            let j = j[l] as usize;
            acc[l] += term(j, g.at(b * ACC + l, j, unchecked));
        }
    }
    for (l, &j) in nb[full..].iter().enumerate() {
        acc[l] += term(j as usize, g.at(full + l, j as usize, unchecked));
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

// The solve's constants (the salva scene's: spacing 0.05 m, dt = 5 ms).
const MASS: Real = 0.125;
const DT: Real = 0.005;
const RHO0: Real = 1000.0;

/// Where the passes read their pair gradients: packed (12 bytes a pair), 16 bytes wide, or as
/// a 4-byte factor on the separation recomputed from the gathered positions.
const PACKED: u8 = 0;
const WIDE16: u8 = 1;
const FACTOR: u8 = 2;

/// DFSPH's rate pass over every chunk (the crate's `rate_pass` with the density solve's
/// one-sided finish), in parallel over the chunks; `G`: where it reads the gradients
/// ([`PACKED`]; [`WIDE16`], 20 bytes a pair with the index; [`FACTOR`], 8 bytes a pair with
/// the index and a gathered position); `U`: the pair's slot and the neighbour's value read
/// without a bounds check, as the crate's passes now read them (every index was checked
/// against the particle count when the data was built).
fn rate<const G: u8, const U: bool>(data: &Data, state: &mut State) {
    let State {
        velocities,
        densities,
        alpha,
        pi,
        rates,
        partials,
        ..
    } = state;
    let arrays = (&velocities[..], &densities[..], &alpha[..]);
    pi.par_chunks_mut(CHUNK)
        .zip(partials.par_iter_mut())
        .zip(rates.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(c, ((pi, partial), rates))| {
            *partial = wide(
                #[inline(always)]
                || rate_chunk::<G, U>(data, c, arrays, (pi, rates)),
            );
        });
}

/// The rate pass over the particles of chunk `c` that `pi` holds: `Dρ_i/Dt = m Σ_j (v_i −
/// v_j)·∇W_ij` into `rates`, the pressure increment into `pi`; returns the chunk's error sum
/// and largest error.
#[inline(always)]
fn rate_chunk<const G: u8, const U: bool>(
    data: &Data,
    c: usize,
    (velocities, densities, alpha): (&[Vec3A], &[Real], &[Real]),
    (pi, rates): (&mut [Real], &mut [Real]),
) -> (f64, Real) {
    let inv_dt2 = 1.0 / (DT * DT);
    assert_eq!(velocities.len(), data.n, "a velocity per particle");
    let chunk = &data.chunks[c];
    let (offsets, indices) = (&chunk.offsets, &chunk.indices);
    let mut err_sum = 0.0f64;
    let mut err_max: Real = 0.0;
    for k in 0..pi.len() {
        let i = c * CHUNK + k;
        let vi = velocities[i];
        let (s, e) = (offsets[k] as usize, offsets[k + 1] as usize);
        // SAFETY: every index is below `data.n` (`Data::new`), the velocities' length.
        let term = |j: usize, g: Vec3A| (vi - unsafe { get(velocities, j, U) }) * g;
        let nb = &indices[s..e];
        let a = match G {
            WIDE16 => pair_sum(nb, &chunk.grad16[s..e], U, term),
            FACTOR => pair_sum(nb, data.factors(c, i, s, e), U, term),
            _ => pair_sum(nb, GradientSlice::new(&chunk.grad, s, e), U, term),
        };
        let rate = (a.x + a.y + a.z) * MASS;
        let excess = (densities[i] + DT * rate - RHO0).max(0.0);
        pi[k] = excess * alpha[i] * inv_dt2;
        rates[k] = rate;
        err_sum += excess as f64;
        err_max = err_max.max(excess);
    }
    (err_sum, err_max)
}

/// The factor passes' results against the packed passes' from the same state, bit for bit
/// (the rate pass's rates and pressure values, the push's velocities and summed pressure);
/// the state is left as it was.
fn check_factor_passes<const U: bool>(data: &Data, state: &mut State) {
    let bits = |v: &[Real]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let vbits = |v: &[Vec3A]| {
        v.iter()
            .flat_map(|x| [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()])
            .collect::<Vec<_>>()
    };
    let (pi0, v0, w0) = (
        state.pi.clone(),
        state.velocities.clone(),
        state.warm.clone(),
    );
    rate::<PACKED, U>(data, state);
    let packed = (bits(&state.rates), bits(&state.pi));
    rate::<FACTOR, U>(data, state);
    assert!(
        packed == (bits(&state.rates), bits(&state.pi)),
        "the factor rate pass differs from the packed one"
    );
    push::<PACKED, U>(data, state);
    let packed = (vbits(&state.velocities), bits(&state.warm));
    (state.velocities, state.warm) = (v0.clone(), w0.clone());
    push::<FACTOR, U>(data, state);
    assert!(
        packed == (vbits(&state.velocities), bits(&state.warm)),
        "the factor push differs from the packed one"
    );
    (state.pi, state.velocities, state.warm) = (pi0, v0, w0);
}

/// Tiny pressure values' scale on the push: the velocities stay finite however many passes
/// run (the cost does not depend on the values).
const PUSH_SCALE: Real = DT * MASS * 1e-12;

/// DFSPH's push pass over every chunk (the crate's `apply_pressure` without walls), in
/// parallel over the chunks; `G`: where it reads the gradients ([`PACKED`] or [`FACTOR`]);
/// `U` as for [`rate`].
fn push<const G: u8, const U: bool>(data: &Data, state: &mut State) {
    let State {
        velocities,
        pi,
        warm,
        ..
    } = state;
    let pi = &pi[..];
    velocities
        .par_chunks_mut(CHUNK)
        .zip(warm.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(c, (out, warm))| {
            wide(
                #[inline(always)]
                || push_chunk::<G, U>(data, c, pi, (out, warm)),
            );
        });
}

/// The push pass over the particles of chunk `c` that `out` holds: `v_i −= dt·m·Σ_j (π_i +
/// π_j) ∇W_ij`, and the solve's summed pressure `warm += π`.
#[inline(always)]
fn push_chunk<const G: u8, const U: bool>(
    data: &Data,
    c: usize,
    pi: &[Real],
    (out, warm): (&mut [Vec3A], &mut [Real]),
) {
    assert_eq!(pi.len(), data.n, "a pressure value per particle");
    let chunk = &data.chunks[c];
    let (offsets, indices) = (&chunk.offsets, &chunk.indices);
    for (k, v) in out.iter_mut().enumerate() {
        let i = c * CHUNK + k;
        let pii = pi[i];
        let (s, e) = (offsets[k] as usize, offsets[k + 1] as usize);
        // SAFETY: every index is below `data.n` (`Data::new`), the pressure values' length.
        let term = |j: usize, g: Vec3A| g * (pii + unsafe { get(pi, j, U) });
        let nb = &indices[s..e];
        let f = if G == FACTOR {
            pair_sum(nb, data.factors(c, i, s, e), U, term)
        } else {
            pair_sum(nb, GradientSlice::new(&chunk.grad, s, e), U, term)
        };
        let dv = Vector::from(f) * PUSH_SCALE;
        *v -= Vec3A::from(dv);
    }
    let own = &pi[c * CHUNK..][..out.len()];
    for (s, &p) in warm.iter_mut().zip(own) {
        *s += p;
    }
}

/// The rate pass (`push == false`) or the push pass in L1: each thread replays the first
/// [`L1_PARTICLES`] particles of the middle chunk (a bulk one) into buffers of its own, for
/// as many pairs in all as a whole pass visits.
fn in_l1<const G: u8, const U: bool>(data: &Data, state: &State, push: bool) -> f64 {
    let c = data.chunks.len() / 2;
    let threads = rayon::current_num_threads();
    let replays = data.pairs.div_ceil(data.l1_pairs * threads);
    let arrays = (
        &state.velocities[..],
        &state.densities[..],
        &state.alpha[..],
    );
    (0..threads)
        .into_par_iter()
        .map(|_| {
            let mut pi = [0.0; L1_PARTICLES];
            let mut rates = [0.0; L1_PARTICLES];
            let mut out = [Vec3A::ZERO; L1_PARTICLES];
            wide(
                #[inline(always)]
                || {
                    let mut sum = 0.0;
                    for _ in 0..replays {
                        // Opaque inputs: no replay can reuse the last one's work.
                        let (data, arrays) = black_box((data, arrays));
                        if push {
                            push_chunk::<G, U>(
                                data,
                                c,
                                black_box(&state.pi),
                                (&mut out, &mut rates),
                            );
                        } else {
                            sum += rate_chunk::<G, U>(data, c, arrays, (&mut pi, &mut rates)).0;
                        }
                        black_box((&mut out, &mut pi, &mut rates));
                    }
                    sum + (out[0].x + rates[0]) as f64
                },
            )
        })
        .sum()
}

/// Runs `f` compiled for AVX-512 (F and VL) or else AVX2 where the CPU has them, as the
/// crate's `par::wide` does for its pair passes.
#[inline(always)]
fn wide<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512vl")
    {
        #[target_feature(enable = "avx2,avx512f,avx512vl")]
        #[inline]
        unsafe fn avx512<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        // SAFETY: AVX-512F/VL were detected at run time.
        return unsafe { avx512(f) };
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        #[target_feature(enable = "avx2")]
        #[inline]
        unsafe fn avx2<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        // SAFETY: AVX2 was detected at run time.
        return unsafe { avx2(f) };
    }
    f()
}

/// The core's clock in GHz, from the time a chain of dependent 64-bit integer multiplications
/// takes (3 cycles each on Intel cores since Sandy Bridge and AMD's since Zen; a chain of
/// additions with an immediate runs faster than one a cycle on recent Intel cores, which fold
/// them at renaming); the fastest of 1,000 samples of about 0.1 ms (short, so that some run unpreempted on a
/// loaded machine). `None` off x86-64.
fn clock_ghz() -> Option<f64> {
    #[cfg(target_arch = "x86_64")]
    {
        let chain = |iterations: u64| {
            let (mut x, mut n) = (3u64, iterations);
            let t0 = Instant::now();
            // SAFETY: register arithmetic and a loop on the two registers given, nothing else.
            unsafe {
                std::arch::asm!(
                    "2:",
                    "imul {x}, {x}",
                    "imul {x}, {x}",
                    "imul {x}, {x}",
                    "imul {x}, {x}",
                    "imul {x}, {x}",
                    "imul {x}, {x}",
                    "imul {x}, {x}",
                    "imul {x}, {x}",
                    "dec {n}",
                    "jnz 2b",
                    x = inout(reg) x,
                    n = inout(reg) n,
                    options(nomem, nostack),
                );
            }
            black_box((x, n));
            24.0 * iterations as f64 / t0.elapsed().as_secs_f64() / 1e9
        };
        Some((0..1000).map(|_| chain(10_000)).fold(0.0, f64::max))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        None
    }
}

fn isa_name() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vl")
        {
            return "AVX-512";
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            return "AVX2";
        }
    }
    "portable"
}

/// The CPU's model name and cache sizes from `/proc/cpuinfo` and sysfs (Linux; "" elsewhere).
fn cpu_name() -> String {
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_default();
    let cache = |k: usize| {
        let dir = format!("/sys/devices/system/cpu/cpu0/cache/index{k}");
        let read = |f: &str| std::fs::read_to_string(format!("{dir}/{f}")).ok();
        match (read("level"), read("type"), read("size")) {
            (Some(l), Some(t), Some(s)) if t.trim() != "Instruction" => {
                Some(format!("L{} {}", l.trim(), s.trim()))
            }
            _ => None,
        }
    };
    let caches: Vec<String> = (0..5).filter_map(cache).collect();
    format!("{model}; {}", caches.join(", "))
}

/// A small deterministic generator (SplitMix64).
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> Real {
        (self.next() >> 40) as Real / (1u64 << 24) as Real
    }
}
