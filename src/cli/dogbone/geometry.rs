//! The dog-bone of Littlewood's "Roadmap for Software Implementation" (2016, §18.8.2; "the
//! roadmap chapter" below): length 10.16 cm, grip width 1.27 cm, gauge width 0.635 cm,
//! thickness 0.315 cm, along y, centred on the origin, width along x, thickness along z.
//!
//! The paper gives no fillet or grip length; these follow Peridigm's `tensile_test` mesh: a
//! straight reduced section 3.81 cm long (|y| ≤ 1.905 cm), circular fillets of radius
//! 0.635 cm tangent to it, reaching the grip width at |y| = 1.905 + √(2Rd − d²) ≈ 2.455 cm
//! (d = 0.3175 cm, the step in half-width), and loaded grip blocks 0.381 cm long at each end.

/// Dimensions of a flat dog-bone specimen (length units of the deck; cm for the chapter's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DogBone {
    /// Overall length along y.
    pub length: f64,
    /// Width of the wide ends (x).
    pub grip_width: f64,
    /// Width of the reduced (gauge) section (x).
    pub gauge_width: f64,
    /// Thickness (z).
    pub thickness: f64,
    /// Length of the straight reduced section, centred on y = 0.
    pub reduced_length: f64,
    /// Radius of the fillets, tangent to the reduced section.
    pub fillet_radius: f64,
    /// Length of each loaded grip block at the ends.
    pub grip_length: f64,
}

/// Number of midpoint samples along y where a cell meets a fillet.
const FILLET_SAMPLES: usize = 64;

/// A cell's intersection with the dog-bone's outline in the x–y plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clipped {
    /// Area inside the outline.
    pub area: f64,
    /// Centroid x of that area.
    pub x: f64,
    /// Centroid y of that area.
    pub y: f64,
}

impl DogBone {
    /// The roadmap chapter's specimen in cm, with the fillet and grips of Peridigm's example.
    pub const ROADMAP: DogBone = DogBone {
        length: 10.16,
        grip_width: 1.27,
        gauge_width: 0.635,
        thickness: 0.315,
        reduced_length: 3.81,
        fillet_radius: 0.635,
        grip_length: 0.381,
    };

    /// Length along y of one fillet: √(2Rd − d²), d the step in half-width.
    pub fn fillet_length(&self) -> f64 {
        let step = (self.grip_width - self.gauge_width) / 2.0;
        (2.0 * self.fillet_radius * step - step * step).sqrt()
    }

    /// Half-width of the outline at height y (0 outside the bar).
    pub fn half_width(&self, y: f64) -> f64 {
        let y = y.abs();
        let start = self.reduced_length / 2.0;
        if y > self.length / 2.0 {
            0.0
        } else if y <= start {
            self.gauge_width / 2.0
        } else if y < start + self.fillet_length() {
            let s = y - start;
            let r = self.fillet_radius;
            self.gauge_width / 2.0 + r - (r * r - s * s).sqrt()
        } else {
            self.grip_width / 2.0
        }
    }

    /// The exact volume: thickness × outline area, the fillets integrated in closed form.
    pub fn volume(&self) -> f64 {
        let r = self.fillet_radius;
        let fillet = self.fillet_length();
        // ∫₀ᴸ √(R² − s²) ds = L/2 √(R² − L²) + R²/2 asin(L/R).
        let circle =
            fillet / 2.0 * (r * r - fillet * fillet).sqrt() + r * r / 2.0 * (fillet / r).asin();
        let fillet_area = (self.gauge_width / 2.0 + r) * fillet - circle;
        let straight = self.reduced_length / 2.0 * self.gauge_width / 2.0;
        let wide = (self.length / 2.0 - self.reduced_length / 2.0 - fillet) * self.grip_width / 2.0;
        4.0 * (straight + fillet_area + wide) * self.thickness
    }

    /// Whether the half-width is constant over [y0, y1] (no fillet inside).
    fn straight_over(&self, y0: f64, y1: f64) -> bool {
        let start = self.reduced_length / 2.0;
        let end = start + self.fillet_length();
        let (low, high) = if y0 >= 0.0 {
            (y0, y1)
        } else if y1 <= 0.0 {
            (-y1, -y0)
        } else {
            (0.0, y1.max(-y0))
        };
        high <= start || low >= end
    }

    /// The area and centroid of the cell [x0, x1] × [y0, y1] inside the outline, exact where
    /// the outline is straight, with midpoint sampling along y across a fillet.
    pub fn clip(&self, x: [f64; 2], y: [f64; 2]) -> Clipped {
        let y_range = [y[0].max(-self.length / 2.0), y[1].min(self.length / 2.0)];
        if y_range[1] <= y_range[0] {
            return Clipped {
                area: 0.0,
                x: 0.0,
                y: 0.0,
            };
        }
        let samples = if self.straight_over(y_range[0], y_range[1]) {
            1
        } else {
            FILLET_SAMPLES
        };
        let dy = (y_range[1] - y_range[0]) / samples as f64;
        let (mut area, mut moment_x, mut moment_y) = (0.0, 0.0, 0.0);
        for k in 0..samples {
            let at = y_range[0] + (k as f64 + 0.5) * dy;
            let w = self.half_width(at);
            let low = x[0].max(-w);
            let high = x[1].min(w);
            if high > low {
                area += (high - low) * dy;
                moment_x += (high * high - low * low) / 2.0 * dy;
                moment_y += at * (high - low) * dy;
            }
        }
        if area == 0.0 {
            return Clipped {
                area,
                x: 0.0,
                y: 0.0,
            };
        }
        Clipped {
            area,
            x: moment_x / area,
            y: moment_y / area,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outline_matches_the_peridigm_mesh() {
        let bone = DogBone::ROADMAP;
        assert!((bone.fillet_length() - 0.5499).abs() < 1e-3);
        assert_eq!(bone.half_width(0.0), 0.3175);
        assert_eq!(bone.half_width(-1.9), 0.3175);
        assert_eq!(bone.half_width(3.0), 0.635);
        assert_eq!(bone.half_width(5.1), 0.0);
        // Peridigm's mesh has a node at y = 2.0839, x = 0.34322 on the fillet.
        assert!((bone.half_width(2.0839) - 0.34322).abs() < 2e-3);
    }

    #[test]
    fn clipping_sums_to_the_closed_form_volume() {
        let bone = DogBone::ROADMAP;
        let h = 0.05;
        let mut area = 0.0;
        for j in -110..110 {
            for i in -15..15 {
                let x = [i as f64 * h, (i + 1) as f64 * h];
                let y = [j as f64 * h, (j + 1) as f64 * h];
                area += bone.clip(x, y).area;
            }
        }
        let exact = bone.volume() / bone.thickness;
        assert!((area - exact).abs() < 1e-5 * exact, "{area} vs {exact}");
        // A cell half outside the gauge edge keeps half its area, centred in its inner half.
        let half = bone.clip([0.3, 0.335], [0.0, 0.035]);
        assert!((half.area - 0.0175 * 0.035).abs() < 1e-15);
        assert!((half.x - 0.30875).abs() < 1e-12);
    }
}
