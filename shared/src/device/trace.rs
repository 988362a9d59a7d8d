//! A signal's history in fixed memory over a stage of unknown length: `C` points, each the
//! mean of `stride` consecutive samples; when full, neighbouring points are averaged in pairs
//! and the stride doubles. The commissioning probe reads time constants off it.

/// The history of one signal, `C` points at most (`C` even).
#[derive(Clone, Debug)]
pub struct Trace<const C: usize> {
    points: [f32; C],
    len: usize,
    stride: u32,
    sum: f32,
    pending: u32,
}

impl<const C: usize> Default for Trace<C> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const C: usize> Trace<C> {
    /// Empty, one sample per point.
    pub const fn new() -> Self {
        Trace {
            points: [0.0; C],
            len: 0,
            stride: 1,
            sum: 0.0,
            pending: 0,
        }
    }

    /// Add the next sample.
    pub fn push(&mut self, x: f32) {
        self.sum += x;
        self.pending += 1;
        if self.pending < self.stride {
            return;
        }
        self.points[self.len] = self.sum / self.stride as f32;
        self.len += 1;
        (self.sum, self.pending) = (0.0, 0);
        if self.len == C {
            for j in 0..C / 2 {
                self.points[j] = 0.5 * (self.points[2 * j] + self.points[2 * j + 1]);
            }
            self.len = C / 2;
            self.stride *= 2;
        }
    }

    /// Samples per point.
    pub fn stride(&self) -> u32 {
        self.stride
    }

    /// The points so far (each the mean of [`Trace::stride`] samples).
    pub fn points(&self) -> &[f32] {
        &self.points[..self.len]
    }

    /// The newest point (0 before the first).
    pub fn last(&self) -> f32 {
        self.points().last().copied().unwrap_or(0.0)
    }

    /// The point that holds sample `k` (the newest when `k` lies beyond it).
    pub fn at_sample(&self, k: u32) -> f32 {
        let j = (k / self.stride) as usize;
        self.points().get(j).copied().unwrap_or_else(|| self.last())
    }

    /// The largest point.
    pub fn max(&self) -> f32 {
        self.points().iter().copied().fold(f32::MIN, f32::max)
    }

    /// Mean of the points.
    pub fn mean(&self) -> f32 {
        let p = self.points();
        p.iter().sum::<f32>() / (p.len().max(1)) as f32
    }

    /// The sample time (in samples from the first, fractional) at which the signal first
    /// reaches `level`, interpolated linearly between the points' centres; `None` if it
    /// never does.
    pub fn first_reaching(&self, level: f32) -> Option<f32> {
        let s = self.stride as f32;
        let centre = |j: usize| (j as f32 + 0.5) * s - 0.5;
        let p = self.points();
        let j = p.iter().position(|&x| x >= level)?;
        if j == 0 {
            // The signal started at 0 before the first sample: interpolate from there.
            let f = if p[0] > 0.0 { level / p[0] } else { 1.0 };
            return Some(f * centre(0).max(0.0));
        }
        let (a, b) = (p[j - 1], p[j]);
        let f = if b > a { (level - a) / (b - a) } else { 1.0 };
        Some(centre(j - 1) + f * s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_signal_is_kept_in_halved_resolution_with_its_means() {
        let mut t = Trace::<8>::new();
        for k in 0..20 {
            t.push(k as f32);
        }
        // 20 samples into 8 points: stride 4 after two halvings (8 -> 4 points at stride 2,
        // 8 -> 4 at stride 4), the last 4 samples make the fifth point.
        assert_eq!(t.stride(), 4);
        assert_eq!(t.points(), &[1.5, 5.5, 9.5, 13.5, 17.5]);
        assert_eq!(t.at_sample(9), 9.5);
        assert_eq!(t.last(), 17.5);
    }

    #[test]
    fn the_time_constant_of_an_exponential_is_read_within_its_resolution() {
        // 1 - e^(-k/tau) reaches 63.2 % at k = tau.
        for tau in [3.0f32, 40.0, 700.0] {
            let mut t = Trace::<64>::new();
            for k in 0..(6.0 * tau) as usize {
                t.push(1.0 - (-(k as f32) / tau).exp());
            }
            let k63 = t.first_reaching(1.0 - (-1.0f32).exp()).unwrap();
            let resolution = t.stride() as f32;
            assert!(
                (k63 - tau).abs() <= 0.6 * resolution + 0.05 * tau,
                "{tau}: {k63}"
            );
        }
        assert_eq!(Trace::<8>::new().first_reaching(1.0), None);
    }
}
