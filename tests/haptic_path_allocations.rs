//! The haptic-loop path (`Spm::track`, `Spm::forward` and `Spm::ik`) must not touch the heap: a counting
//! global allocator (this test binary only) sees every allocation.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use nalgebra::Vector3;
use spmcal::math::so3;
use spmcal::model::Spm;

struct Counting;
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn tracking_a_trajectory_does_not_allocate() {
    let spm = Spm::agile_wrist_nominal();
    // A 1 kHz trajectory: one second of a 20° tilt swept once around.
    let orientations: Vec<_> = (0..1000)
        .map(|k| {
            let az = std::f64::consts::TAU * k as f64 / 1000.0;
            so3::exp(&(Vector3::new(az.cos(), az.sin(), 0.0) * 20f64.to_radians()))
        })
        .collect();
    let joints: Vec<_> = orientations.iter().map(|r| spm.ik(r).unwrap()).collect();
    let mut r = orientations[0];
    let before = ALLOCATIONS.load(Ordering::SeqCst);
    for (j, expected) in joints.iter().zip(&orientations) {
        r = spm.track(j, &r).unwrap();
        let _ = spm.ik(expected).unwrap();
        // The working-mode FDA from home, the entry point without a previous pose.
        let from_home = spm.forward(j).unwrap();
        assert!(so3::geodesic_angle(&from_home, expected) < 1e-12);
        assert!(so3::geodesic_angle(&r, expected) < 1e-12);
    }
    let after = ALLOCATIONS.load(Ordering::SeqCst);
    assert_eq!(after - before, 0, "the haptic path allocated {} times", after - before);
}
