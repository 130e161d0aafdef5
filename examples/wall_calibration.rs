//! The wall term against a lattice continuing behind the wall, without dynamics.
//!
//! ```text
//! cargo run --release --example wall_calibration            # both parts, N = 6 and 8
//! cargo run --release --example wall_calibration -- 1       # part 1 only
//! cargo run --release --example wall_calibration -- 2 6,8,12
//! ```
//!
//! **Part 1.** For each kernel at `h = 2s`, a particle at height `z` above a wall: the wall's
//! density `Φ_s(z)`, the normal part of its gradient `A(z)` and of its first moment `M(z)`
//! (the tables of `rapier_sph::kernel::half_space`, in units of `ρ0`), against the sums over
//! the lattice sites the wall takes the place of (ghost rows at `−s/2 − k·s`), with the
//! particle on a site of that lattice (`off = (0, 0)`, the fluid's own lattice continued) or
//! offset from it in the plane.
//!
//! **Part 2.** A column `n × 2n × n` on the lattice the hydrostatic tank starts from (spacing
//! `0.1/n`, cubic spline, `h = 2s`), positions fixed at the lattice: the pressures that make
//! every particle's acceleration (DFSPH's pressure force, walls, gravity) as close to zero as
//! possible, by least squares. Walls either as ghost lattice sites carrying Adami et al.'s
//! pressure `p_b = p_i + ρ0·g·(y_i − y_b)`, or as the crate's half-space tables with mirror
//! weight `γ` (and the hydrostatic moment term when `hydro`), optionally scaled. Prints the
//! bottom layer's pressure error as `HydrostaticTank::bottom_pressure_error` measures it, each
//! layer's pressure over `ρ0·g·depth` (next to a side wall / inside), the residual vertical
//! acceleration per layer, and the vertical force the walls carry as fractions of the weight.
use rapier_sph::kernel::{CubicSpline, HalfSpaceTable, Kernel, Poly6, Spiky, WendlandC2};
use rapier_sph::math::Real;

/// Part 1 for kernel `K` at spacing `s`.
fn part1<K: Kernel>(s: f64) {
    let h = 2.0 * s;
    let k = K::new(h as Real);
    let t = HalfSpaceTable::new::<K>(h as Real, s as Real);
    let w = |r: f64| k.w(r as Real) as f64;
    let dw = |r: f64| k.dw(r as Real) as f64;
    let v = s * s * s;
    let (mut full, mut full_mom) = (0.0, 0.0);
    for i in -4i32..=4 {
        for j in -4i32..=4 {
            for l in -4i32..=4 {
                let p = [i as f64 * s, j as f64 * s, l as f64 * s];
                let d = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                full += v * w(d);
                if d > 0.0 {
                    full_mom += v * -dw(d) / d * p[2] * p[2];
                }
            }
        }
    }
    println!(
        "{}: full lattice: density {full:.5} (table {:.5}), normal first moment {full_mom:.5}",
        K::NAME,
        t.full()
    );
    let pct = |table: f64, lattice: f64| 100.0 * (table / lattice - 1.0);
    for (z, ox, oy) in [
        (0.5, 0.0, 0.0),
        (0.5, 0.5, 0.0),
        (0.5, 0.5, 0.5),
        (0.45, 0.0, 0.0),
        (0.55, 0.0, 0.0),
    ] {
        let z = z * s;
        let (mut rho, mut grad, mut mom) = (0.0, 0.0, 0.0);
        for i in -5i32..=5 {
            for j in -5i32..=5 {
                for l in 0..5 {
                    let (dx, dy) = ((i as f64 + ox) * s, (j as f64 + oy) * s);
                    let dz = z + 0.5 * s + l as f64 * s;
                    let d = (dx * dx + dy * dy + dz * dz).sqrt();
                    rho += v * w(d);
                    grad += v * -dw(d) * dz / d;
                    mom += v * -dw(d) / d * dz * dz;
                }
            }
        }
        let (phi, area) = t.eval(z as Real);
        let (_, m) = t.eval_moment(z as Real);
        println!(
            "  z = {:.2} s, off = ({ox}, {oy}): density lattice {rho:.5} table {phi:.5} ({:+.2} %) | \
             |grad|·s lattice {:.5} table {:.5} ({:+.2} %) | moment lattice {mom:.5} table {m:.5} ({:+.2} %)",
            z / s,
            pct(phi as f64, rho),
            grad * s,
            area as f64 * s,
            pct(area as f64, grad),
            pct(m as f64, mom)
        );
    }
}

/// How part 2 models the walls.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Walls {
    /// Ghost lattice sites with Adami's hydrostatic pressure.
    Ghost,
    /// The half-space tables, mirror weight `gamma`, the hydrostatic moment term if `hydro`,
    /// gradient and moments multiplied by `scale`.
    Table { gamma: f64, hydro: bool, scale: f64 },
}

/// The box's five faces seen from `x`: (inward normal, distance).
fn faces(x: [f64; 3], size: [f64; 3]) -> [([f64; 3], f64); 5] {
    [
        ([0.0, 1.0, 0.0], x[1]),
        ([1.0, 0.0, 0.0], x[0]),
        ([-1.0, 0.0, 0.0], size[0] - x[0]),
        ([0.0, 0.0, 1.0], x[2]),
        ([0.0, 0.0, -1.0], size[2] - x[2]),
    ]
}

/// Part 2 for an `n × 2n × n` column.
fn part2(n: usize, walls: Walls) {
    let s = 0.1 / n as f64;
    let h = 2.0 * s;
    let k = CubicSpline::new(h as Real);
    let t = HalfSpaceTable::new::<CubicSpline>(h as Real, s as Real);
    let full = t.full() as f64;
    let dw = |r: f64| k.dw(r as Real) as f64;
    let (rho0, g) = (1000.0f64, 9.81f64);
    let m = rho0 * s * s * s;
    let (nx, ny, nz) = (n, 2 * n, n);
    let size = [nx as f64 * s, ny as f64 * s, nz as f64 * s];
    let site = |i: i32, j: i32, l: i32| {
        [
            (i as f64 + 0.5) * s,
            (j as f64 + 0.5) * s,
            (l as f64 + 0.5) * s,
        ]
    };
    let mut pos = Vec::new();
    for i in 0..nx as i32 {
        for j in 0..ny as i32 {
            for l in 0..nz as i32 {
                pos.push(site(i, j, l));
            }
        }
    }
    let np = pos.len();
    // Ghost sites: outside the box's floor and sides, below the free surface's height.
    let mut ghosts = Vec::new();
    if walls == Walls::Ghost {
        for i in -3..nx as i32 + 3 {
            for j in -3..ny as i32 {
                for l in -3..nz as i32 + 3 {
                    let inside = (0..nx as i32).contains(&i) && (0..nz as i32).contains(&l);
                    if !(inside && j >= 0) {
                        ghosts.push(site(i, j, l));
                    }
                }
            }
        }
    }
    // a = B·p + c, three rows per particle; B as (row, column, value).
    let mut b: Vec<(usize, usize, f64)> = Vec::new();
    let mut c = vec![0.0f64; 3 * np];
    // Vertical bookkeeping: floor's coefficient on p_i, floor's and sides' constant terms.
    let (mut kf, mut cf, mut cs) = (vec![0.0; np], vec![0.0; np], vec![0.0; np]);
    let dist = |a: [f64; 3], b: [f64; 3]| {
        let r = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        (r, (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt())
    };
    for (i, &xi) in pos.iter().enumerate() {
        c[3 * i + 1] -= g;
        for (j, &xj) in pos.iter().enumerate() {
            let (r, d) = dist(xi, xj);
            if j == i || d >= h {
                continue;
            }
            for (a, ra) in r.iter().enumerate() {
                // a_i = −Σ m (p_i + p_j)/ρ0² ∇W_ij
                let coef = -m * dw(d) * ra / d / (rho0 * rho0);
                b.push((3 * i + a, i, coef));
                b.push((3 * i + a, j, coef));
            }
        }
        match walls {
            Walls::Ghost => {
                for &xb in &ghosts {
                    let (r, d) = dist(xi, xb);
                    if d >= h {
                        continue;
                    }
                    let dp = rho0 * g * (xi[1] - xb[1]);
                    for a in 0..3 {
                        let coef = -m * dw(d) * r[a] / d / (rho0 * rho0);
                        b.push((3 * i + a, i, 2.0 * coef));
                        c[3 * i + a] += coef * dp;
                        if a == 1 {
                            if xb[1] < 0.0 {
                                kf[i] += 2.0 * coef;
                                cf[i] += coef * dp;
                            } else {
                                cs[i] += coef * dp;
                            }
                        }
                    }
                }
            }
            Walls::Table {
                gamma,
                hydro,
                scale,
            } => {
                // The union of half-spaces of `boundary::wall`.
                let (mut u, mut gv, mut hs) = (0.0f64, [0.0f64; 3], [0.0f64; 3]);
                let grav = [0.0, -g, 0.0];
                for (nrm, d) in faces(xi, size) {
                    if d >= h {
                        continue;
                    }
                    let (phi, area) = t.eval(d as Real);
                    let (phi_t, mom) = t.eval_moment(d as Real);
                    let (area, mom, phi_t) = (
                        area as f64 * scale,
                        mom as f64 * scale,
                        phi_t as f64 * scale,
                    );
                    let a = (phi as f64 / full).min(1.0);
                    let gn = nrm[1] * grav[1];
                    for q in 0..3 {
                        let hk = -(nrm[q] * gn * mom + (grav[q] - nrm[q] * gn) * phi_t) * (1.0 - u);
                        hs[q] = hs[q] * (1.0 - a) + hk;
                        gv[q] = gv[q] * (1.0 - a) - nrm[q] * area / full * (1.0 - u);
                        if q == 1 && hydro {
                            cf[i] = cf[i] * (1.0 - a) - nrm[q] * gn * mom * (1.0 - u);
                            cs[i] = cs[i] * (1.0 - a) - (grav[q] - nrm[q] * gn) * phi_t * (1.0 - u);
                        }
                    }
                    u = 1.0 - (1.0 - u) * (1.0 - a);
                }
                for q in 0..3 {
                    // a −= γ·π_i·∇ρ_wall
                    let coef = -gamma * gv[q] * rho0 * full / (rho0 * rho0);
                    b.push((3 * i + q, i, coef));
                    if q == 1 {
                        kf[i] = coef;
                    }
                    if hydro {
                        c[3 * i + q] += hs[q];
                    }
                }
            }
        }
    }
    // Conjugate gradients on the normal equations BᵀB p = −Bᵀc, from the hydrostatic field.
    let mul = |x: &[f64]| {
        let mut y = vec![0.0; 3 * np];
        for &(r, col, v) in &b {
            y[r] += v * x[col];
        }
        y
    };
    let mul_t = |y: &[f64]| {
        let mut x = vec![0.0; np];
        for &(r, col, v) in &b {
            x[col] += v * y[r];
        }
        x
    };
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(a, b)| a * b).sum::<f64>();
    let rhs = mul_t(&c.iter().map(|v| -v).collect::<Vec<_>>());
    let mut p: Vec<f64> = pos.iter().map(|x| rho0 * g * (size[1] - x[1])).collect();
    let mut r: Vec<f64> = rhs
        .iter()
        .zip(mul_t(&mul(&p)))
        .map(|(a, b)| a - b)
        .collect();
    let mut d = r.clone();
    let mut rr = dot(&r, &r);
    let r0 = rr.sqrt();
    let mut it = 0;
    while it < 20_000 && rr.sqrt() > 1e-10 * r0 {
        let ad = mul_t(&mul(&d));
        let alpha = rr / dot(&d, &ad);
        for q in 0..np {
            p[q] += alpha * d[q];
            r[q] -= alpha * ad[q];
        }
        let next = dot(&r, &r);
        for q in 0..np {
            d[q] = r[q] + next / rr * d[q];
        }
        rr = next;
        it += 1;
    }
    let resid: Vec<f64> = mul(&p).iter().zip(&c).map(|(a, b)| a + b).collect();
    let rms = (dot(&resid, &resid) / resid.len() as f64).sqrt();
    let (mut measured, mut expected) = (0.0, 0.0);
    let mut layers = vec![[0.0f64; 4]; ny];
    let mut vertical = vec![0.0f64; ny];
    for (q, x) in pos.iter().enumerate() {
        let e = rho0 * g * (size[1] - x[1]);
        if x[1] < s {
            measured += p[q];
            expected += e;
        }
        let l = (x[1] / s) as usize;
        let side = x[0] < s || x[2] < s || x[0] > size[0] - s || x[2] > size[2] - s;
        let o = if side { 0 } else { 2 };
        layers[l][o] += p[q];
        layers[l][o + 1] += e;
        vertical[l] += resid[3 * q + 1] / (nx * nz) as f64;
    }
    println!(
        "N = {n}, {walls:?}: bottom error {:+.2} %, residual acceleration RMS {:.2} % of g ({it} CG iterations)",
        100.0 * (measured / expected - 1.0),
        100.0 * rms / g
    );
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { f64::NAN };
    let line: Vec<String> = layers
        .iter()
        .map(|l| format!("{:.3}/{:.3}", ratio(l[0], l[1]), ratio(l[2], l[3])))
        .collect();
    println!(
        "  p / ρ0 g depth per layer (side / inside): {}",
        line.join(" ")
    );
    let line: Vec<String> = vertical.iter().map(|v| format!("{:+.3}", v / g)).collect();
    println!("  mean vertical residual / g per layer: {}", line.join(" "));
    let weight = np as f64 * g;
    let f0 = dot(&kf, &p) / weight;
    let (f1, f2) = (
        cf.iter().sum::<f64>() / weight,
        cs.iter().sum::<f64>() / weight,
    );
    println!(
        "  vertical wall forces / weight: floor pressure term {f0:.4}, floor hydrostatic {f1:.4}, \
         sides' hydrostatic {f2:.4} (ghosts: the sides' pressure terms left out)"
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let part = args.first().map(String::as_str);
    if part.is_none() || part == Some("1") {
        let s = 0.0125;
        part1::<CubicSpline>(s);
        part1::<WendlandC2>(s);
        part1::<Poly6>(s);
        part1::<Spiky>(s);
    }
    if part.is_none() || part == Some("2") {
        let ns: Vec<usize> = match args.get(1) {
            Some(v) => v
                .split(',')
                .map(|x| {
                    x.parse().unwrap_or_else(|_| {
                        eprintln!("not a resolution: {x:?}");
                        std::process::exit(2)
                    })
                })
                .collect(),
            None => vec![6, 8],
        };
        // The aligned lattice's |∇ρ| at s/2 over the table's (part 1, cubic spline).
        let lattice = 0.51002 / 0.50001;
        for &n in &ns {
            part2(n, Walls::Ghost);
            for (gamma, hydro, scale) in [(2.0, true, 1.0), (2.0, true, lattice), (1.0, false, 1.0)]
            {
                part2(
                    n,
                    Walls::Table {
                        gamma,
                        hydro,
                        scale,
                    },
                );
            }
        }
    }
}
