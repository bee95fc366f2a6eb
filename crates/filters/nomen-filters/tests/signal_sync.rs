//! Window synchronisation: lowest-rate grid, reordering, duplicates, silence, clock offsets.

use nomen_core::SessionTime;
use nomen_filters::sync::{
    PushOutcome, ResampleMethod, SourceConfig, StreamStatus, SyncConfig, SyncedWindow, WindowSync,
};

const MS: i64 = 1_000_000;

fn config() -> SyncConfig {
    SyncConfig {
        window_ns: 1000 * MS,
        hop_ns: 500 * MS,
        coverage_tolerance_ns: 40 * MS,
        max_gap_ns: 80 * MS,
        reorder_window_ns: 50 * MS,
        silence_timeout_ns: 300 * MS,
        resample: ResampleMethod::BinAverage,
        first_window_start: Some(SessionTime::ZERO),
    }
}

/// 100 Hz value: time in seconds; 30 Hz value: 10 × time in seconds.
fn imu_t(i: i64) -> SessionTime {
    SessionTime::from_ns(i * 10 * MS)
}
fn cam_t(i: i64) -> SessionTime {
    SessionTime::from_ns(i * 1_000_000_000 / 30 + 2 * MS)
}

#[test]
fn hundred_hz_imu_and_thirty_hz_camera_align_on_the_camera_grid() {
    let mut sync = WindowSync::new(config()).unwrap();
    let imu = sync
        .add_source(SourceConfig {
            dim: 1,
            clock_offset_ns: 0,
        })
        .unwrap();
    let cam = sync
        .add_source(SourceConfig {
            dim: 2,
            clock_offset_ns: 0,
        })
        .unwrap();
    // Interleave as a real recording would, camera frames arriving in bursts.
    let (mut i, mut j) = (0, 0);
    while i < 150 || j < 45 {
        if i < 150 && (j >= 45 || imu_t(i) <= cam_t(j) + 20 * MS) {
            let t = imu_t(i);
            assert_eq!(
                sync.push(imu, t, &[t.as_secs_f64()]).unwrap(),
                PushOutcome::Accepted
            );
            i += 1;
        } else {
            let t = cam_t(j);
            let v = [10.0 * t.as_secs_f64(), -1.0];
            assert_eq!(sync.push(cam, t, &v).unwrap(), PushOutcome::Accepted);
            j += 1;
        }
    }
    let mut w = SyncedWindow::default();
    assert!(sync.poll(SessionTime::from_ns(1500 * MS), &mut w));
    assert_eq!(w.grid_source, Some(cam));
    let rate = w.rate_hz.unwrap();
    assert!((rate - 30.0).abs() < 0.1, "{rate}");
    assert_eq!(w.grid.len(), 30, "one second of 30 Hz frames");
    for (k, t) in w.grid.iter().enumerate() {
        assert_eq!(*t, cam_t(k as i64), "grid is the camera's own timestamps");
        let cam_row = w.streams[cam.0].row(k).unwrap();
        assert_eq!(
            cam_row,
            [10.0 * t.as_secs_f64(), -1.0],
            "camera passes unchanged"
        );
        // IMU value = its time: the bin average of a ramp sits within half an IMU period
        // of the grid time.
        let imu_v = w.streams[imu.0].row(k).unwrap()[0];
        assert!(
            (imu_v - t.as_secs_f64()).abs() <= 0.005 + 1e-12,
            "{k}: {imu_v} vs {t}"
        );
    }
    assert_eq!(w.streams[imu.0].num_raw_samples, 100);
    // The second window (hop 0.5 s) is waiting for data past 1.5 s.
    assert!(!sync.poll(SessionTime::from_ns(1500 * MS), &mut w));
}

#[test]
fn out_of_order_samples_within_the_reorder_window_are_accepted_and_sorted() {
    let mut sync = WindowSync::new(SyncConfig {
        resample: ResampleMethod::Nearest,
        ..config()
    })
    .unwrap();
    let a = sync
        .add_source(SourceConfig {
            dim: 1,
            clock_offset_ns: 0,
        })
        .unwrap();
    // Swap every pair of 100 Hz samples (10 ms late, within 50 ms).
    for i in (0..120).step_by(2) {
        for k in [i + 1, i] {
            let out = sync.push(a, imu_t(k), &[k as f64]).unwrap();
            assert_eq!(out, PushOutcome::Accepted);
        }
    }
    // 100 ms late: beyond the reorder window.
    assert_eq!(
        sync.push(a, SessionTime::from_ns(1085 * MS), &[0.0])
            .unwrap(),
        PushOutcome::RejectedLate
    );
    let mut w = SyncedWindow::default();
    assert!(sync.poll(SessionTime::from_ns(1100 * MS), &mut w));
    let s = &w.streams[a.0];
    assert_eq!(s.status, StreamStatus::Complete);
    let values: Vec<f64> = (0..w.grid.len()).map(|k| s.row(k).unwrap()[0]).collect();
    assert_eq!(values, (0..100).map(f64::from).collect::<Vec<_>>());
    assert_eq!(sync.counters(a).unwrap().num_late, 1);
}

#[test]
fn duplicate_samples_are_rejected_and_counted() {
    let mut sync = WindowSync::new(config()).unwrap();
    let a = sync
        .add_source(SourceConfig {
            dim: 1,
            clock_offset_ns: 0,
        })
        .unwrap();
    for i in 0..20 {
        sync.push(a, imu_t(i), &[1.0]).unwrap();
    }
    assert_eq!(
        sync.push(a, imu_t(19), &[2.0]).unwrap(),
        PushOutcome::RejectedDuplicate
    );
    assert_eq!(
        sync.push(a, imu_t(17), &[2.0]).unwrap(),
        PushOutcome::RejectedDuplicate
    );
    assert_eq!(
        sync.push(a, imu_t(20), &[f64::NAN]).unwrap(),
        PushOutcome::RejectedNonFinite
    );
    let c = sync.counters(a).unwrap();
    assert_eq!(
        (c.num_accepted, c.num_duplicates, c.num_non_finite),
        (20, 2, 1)
    );
    assert!(
        sync.push(a, imu_t(21), &[1.0, 2.0]).is_err(),
        "wrong dimension is an error"
    );
}

#[test]
fn silent_source_is_marked_missing_after_the_timeout_and_never_blocks() {
    let mut sync = WindowSync::new(config()).unwrap();
    let imu = sync
        .add_source(SourceConfig {
            dim: 1,
            clock_offset_ns: 0,
        })
        .unwrap();
    let cam = sync
        .add_source(SourceConfig {
            dim: 1,
            clock_offset_ns: 0,
        })
        .unwrap();
    for i in 0..200 {
        sync.push(imu, imu_t(i), &[0.0]).unwrap();
    }
    // The camera sends 0.3 s and dies.
    for j in 0..9 {
        sync.push(cam, cam_t(j), &[0.0]).unwrap();
    }
    let mut w = SyncedWindow::default();
    assert!(
        !sync.poll(SessionTime::from_ns(1200 * MS), &mut w),
        "still within the timeout"
    );
    assert!(sync.poll(SessionTime::from_ns(1300 * MS), &mut w));
    assert_eq!(w.streams[cam.0].status, StreamStatus::Incomplete);
    assert!(w.streams[cam.0].is_missing() && w.streams[cam.0].values.is_empty());
    assert_eq!(w.streams[imu.0].status, StreamStatus::Complete);
    assert_eq!(w.grid.len(), 100, "the IMU alone defines the grid");
    // Next window [0.5, 1.5): no camera samples at all.
    assert!(sync.poll(SessionTime::from_ns(1800 * MS), &mut w));
    assert_eq!(w.streams[cam.0].status, StreamStatus::Silent);
    assert_eq!(sync.num_windows(), 2);
}

#[test]
fn clock_offset_is_applied_on_ingest() {
    let mut sync = WindowSync::new(config()).unwrap();
    let a = sync
        .add_source(SourceConfig {
            dim: 1,
            clock_offset_ns: 0,
        })
        .unwrap();
    let b = sync
        .add_source(SourceConfig {
            dim: 1,
            clock_offset_ns: 0,
        })
        .unwrap();
    // b's clock runs 250 ms ahead: plug in the estimated offset.
    sync.set_clock_offset_ns(b, -250 * MS).unwrap();
    for i in 0..120 {
        sync.push(a, imu_t(i), &[imu_t(i).as_secs_f64()]).unwrap();
        let device_t = SessionTime::from_ns(i * 20 * MS + 250 * MS);
        sync.push(b, device_t, &[(device_t - 250 * MS).as_secs_f64()])
            .unwrap();
    }
    let mut w = SyncedWindow::default();
    assert!(sync.poll(SessionTime::from_ns(3000 * MS), &mut w));
    assert_eq!(w.grid_source, Some(b), "50 Hz is the lower rate");
    assert_eq!(w.grid.first(), Some(&SessionTime::ZERO));
    for k in 0..w.grid.len() {
        let (va, vb) = (
            w.streams[a.0].row(k).unwrap()[0],
            w.streams[b.0].row(k).unwrap()[0],
        );
        assert!((va - vb).abs() < 0.0051, "{k}: {va} vs {vb}");
    }
    assert!(
        sync.set_clock_offset_ns(nomen_filters::sync::SourceId(9), 0)
            .is_err()
    );
}

#[test]
fn stamps_beyond_150_years_are_refused_and_no_window_leaves_the_clock() {
    let edge_ns = (nomen_core::MAX_ABS_SESSION_TIME_S * 1e9) as i64;
    let mut sync = WindowSync::new(SyncConfig {
        first_window_start: Some(SessionTime::from_ns(edge_ns - 3_200 * MS)),
        ..config()
    })
    .unwrap();
    let a = sync
        .add_source(SourceConfig {
            dim: 1,
            clock_offset_ns: 0,
        })
        .unwrap();
    let shifted = sync
        .add_source(SourceConfig {
            dim: 1,
            clock_offset_ns: i64::MAX / 2,
        })
        .unwrap();
    // 100 Hz up to 10 ms before the edge; then the clock's end, directly and by an offset.
    for i in (1..=320).rev() {
        let t = SessionTime::from_ns(edge_ns - i * 10 * MS);
        assert_eq!(sync.push(a, t, &[1.0]).unwrap(), PushOutcome::Accepted);
    }
    for (source, t) in [
        (a, i64::MAX),
        (a, edge_ns + MS),
        (shifted, edge_ns / 2 + MS),
    ] {
        assert_eq!(
            sync.push(source, SessionTime::from_ns(t), &[1.0]).unwrap(),
            PushOutcome::RejectedImplausibleTime,
            "{t}"
        );
    }
    assert_eq!(sync.counters(a).unwrap().num_implausible_time, 2);
    assert_eq!(sync.counters(shifted).unwrap().num_implausible_time, 1);
    // Polled at the clock's end, the windows stop where the plausible range does: the five
    // that end within it (the next would end 0.3 s past it), not the same window for ever.
    let mut w = SyncedWindow::default();
    let mut ends = Vec::new();
    while ends.len() < 100 && sync.poll(SessionTime::from_ns(i64::MAX), &mut w) {
        ends.push(w.end.as_ns() - edge_ns);
    }
    assert_eq!(ends, [-2_200, -1_700, -1_200, -700, -200].map(|ms| ms * MS));
}
