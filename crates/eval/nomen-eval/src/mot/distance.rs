//! Distances between ground-truth objects and hypotheses.

use serde::{Deserialize, Serialize};

/// An axis-aligned image rectangle, in pixels, in py-motmetrics' convention: `left`/`top` are
/// 0-based (the MOTChallenge loader subtracts 1 from the file's 1-based values).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BoundingBox {
    /// Left edge, px.
    pub left: f64,
    /// Top edge, px.
    pub top: f64,
    /// Width, px.
    pub width: f64,
    /// Height, px.
    pub height: f64,
}

impl BoundingBox {
    /// Intersection over union with `other`, in `[0, 1]`; 0 when the boxes do not overlap.
    ///
    /// The arithmetic follows `motmetrics.distances.boxiou` operation by operation (sizes are
    /// recomputed as `max - min`, clamped at 0), so results are bit-equal to py-motmetrics.
    pub fn iou(&self, other: &Self) -> f64 {
        let (a_min_x, a_min_y) = (self.left, self.top);
        let (a_max_x, a_max_y) = (self.left + self.width, self.top + self.height);
        let (b_min_x, b_min_y) = (other.left, other.top);
        let (b_max_x, b_max_y) = (other.left + other.width, other.top + other.height);
        let i_width = (a_max_x.min(b_max_x) - a_min_x.max(b_min_x)).max(0.0);
        let i_height = (a_max_y.min(b_max_y) - a_min_y.max(b_min_y)).max(0.0);
        let i_area = i_width * i_height;
        let a_area = (a_max_x - a_min_x).max(0.0) * (a_max_y - a_min_y).max(0.0);
        let b_area = (b_max_x - b_min_x).max(0.0) * (b_max_y - b_min_y).max(0.0);
        let u_area = a_area + b_area - i_area;
        if i_area == 0.0 { 0.0 } else { i_area / u_area }
    }
}

/// Row-major `objects.len() x hypotheses.len()` matrix of IoU distances `1 - IoU`, with NaN
/// ("cannot pair") where the distance exceeds `max_distance`: py-motmetrics'
/// `iou_matrix(objs, hyps, max_iou=max_distance)`. Empty if either list is.
pub fn iou_distance_matrix(
    objects: &[BoundingBox],
    hypotheses: &[BoundingBox],
    max_distance: f64,
) -> Vec<f64> {
    let mut out = Vec::with_capacity(objects.len() * hypotheses.len());
    for o in objects {
        for h in hypotheses {
            let distance = 1.0 - o.iou(h);
            out.push(if distance > max_distance {
                f64::NAN
            } else {
                distance
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bbox(left: f64, top: f64, width: f64, height: f64) -> BoundingBox {
        BoundingBox {
            left,
            top,
            width,
            height,
        }
    }

    #[test]
    fn half_overlapping_squares_have_iou_one_third() {
        let a = bbox(0.0, 0.0, 2.0, 2.0);
        let b = bbox(1.0, 0.0, 2.0, 2.0);
        assert!((a.iou(&b) - 1.0 / 3.0).abs() < 1e-15);
        assert_eq!(a.iou(&a), 1.0);
    }

    #[test]
    fn disjoint_and_touching_boxes_have_zero_iou() {
        let a = bbox(0.0, 0.0, 1.0, 1.0);
        assert_eq!(a.iou(&bbox(1.0, 0.0, 1.0, 1.0)), 0.0);
        assert_eq!(a.iou(&bbox(5.0, 5.0, 1.0, 1.0)), 0.0);
        // A degenerate box overlaps nothing.
        assert_eq!(a.iou(&bbox(0.5, 0.5, 0.0, 0.0)), 0.0);
    }

    #[test]
    fn distances_beyond_the_gate_are_nan() {
        let objects = [bbox(0.0, 0.0, 2.0, 2.0)];
        let hyps = [
            bbox(0.0, 0.0, 2.0, 2.0),
            bbox(1.0, 0.0, 2.0, 2.0),
            bbox(0.0, 0.0, 2.0, 1.0),
        ];
        let d = iou_distance_matrix(&objects, &hyps, 0.5);
        assert_eq!(d[0], 0.0);
        assert!(d[1].is_nan(), "1 - 1/3 > 0.5");
        assert_eq!(d[2], 0.5, "exactly at the gate is kept");
        assert!(iou_distance_matrix(&[], &hyps, 0.5).is_empty());
    }
}
