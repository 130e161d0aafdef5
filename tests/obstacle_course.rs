//! The obstacle course (`scenes::obstacle_course`, the `obstacle_course` example's scene), a
//! short coarse run to its end: no particle lost (every emitted particle is live, drained or
//! quarantined at every step), none inside a solid (fixed, kinematic or dynamic), no NaN,
//! and the bucket filling.

use rapier_sph::FluidParamsBuilder;
use rapier_sph::scenes::{ObstacleCourseConfig, obstacle_course};

#[test]
fn the_course_runs_to_its_end_and_fills_the_bucket() {
    // 5 cm particles: about 750 emitted in 3.5 s; the water reaches the bucket after ~1.5 s.
    let params = FluidParamsBuilder::water(0.05).build().unwrap();
    let mut course = obstacle_course(&ObstacleCourseConfig::new(params)).unwrap();
    let mut solids = course.solids.clone();
    for &b in course.crates.iter().chain([&course.wheel]) {
        solids.extend_from_slice(course.world.physics.bodies[b].colliders());
    }
    let (mut emitted, mut drained, mut quarantined) = (0usize, 0usize, 0usize);
    let mut in_bucket_at_2_5 = 0;
    for frame in 1..=210 {
        let r = course.world.step().unwrap().clone();
        emitted += r.emitted;
        drained += r.drained;
        quarantined += r.quarantined;
        let f = &course.world.fluids[course.fluid];
        assert_eq!(
            f.len() + drained + quarantined,
            emitted,
            "frame {frame}: particles lost"
        );
        assert_eq!(quarantined, 0, "frame {frame}: NaN particles");
        if frame % 10 == 0 {
            let colliders = &course.world.physics.colliders;
            for p in f.positions() {
                for &h in &solids {
                    let co = &colliders[h];
                    assert!(
                        !co.shape().contains_point(co.position(), *p),
                        "frame {frame}: particle {p} inside a solid"
                    );
                }
            }
        }
        if frame == 150 {
            in_bucket_at_2_5 = course.bucket().0.particles;
        }
    }
    let (bucket, fill) = course.bucket();
    eprintln!(
        "emitted {emitted}, drained {drained}, in bucket {} at 2.5 s and {} at 3.5 s (fill {:.1} mm)",
        in_bucket_at_2_5,
        bucket.particles,
        fill * 1e3
    );
    assert!(emitted > 500);
    assert!(
        bucket.particles > in_bucket_at_2_5,
        "the bucket is not filling"
    );
    assert!(in_bucket_at_2_5 > 0, "no water reached the bucket in 2.5 s");
}
