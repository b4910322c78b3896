//! Image-domain metric (Ren 2013 eq. 19): loudness (sone) over time frames and critical bands.
//!
//! Both images share one grid: Hann frames of `W ≈ 23 ms` (a power of two) every `W/4`, and 25
//! bands of one Bark each. A cell holds the loudness of the band's mean-square level in that
//! frame, as a pure tone at the band's centre frequency (ISO 226 via [`crate::psycho`]; masking
//! is ignored, as in the paper).
//!
//! - [`image_of_signal`] is the straightforward route: STFT, sum |X|² over the band's bins.
//! - [`image_of_modes`] is the fast route for the optimizer: a damped sinusoid's STFT cells are
//!   known in closed form ([`resound_signal::stft::ModeColumns`]) and a frame shift only
//!   multiplies them by `z^hop`, so the image of any mode set needs no synthesis and no FFT: the
//!   complex cells within a few dozen bins of each mode (while it lasts) are summed coherently,
//!   then squared into bands. It equals the STFT route to about 1e-6 (test), window spread and
//!   interference between overlapping modes included.

use realfft::num_complex::Complex64;
use resound_core::DampedMode;
use resound_signal::psycho::{bark, phon_for_spl, sone_for_phon, FULL_SCALE_DB_SPL};
use resound_signal::stft::{hann, ModeColumns, Spectrogram};

/// Number of one-Bark bands.
pub const BANDS: usize = 25;

/// Frame and band layout shared by the images compared.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageGrid {
    /// Sample rate in Hz.
    pub sample_rate_hz: f64,
    /// Frame (window) length in samples.
    pub window_len: usize,
    /// Hop in samples (window/4, as [`Spectrogram`]).
    pub hop: usize,
    /// Number of frames.
    pub frames: usize,
    /// Centre frequency of each band (Hz).
    pub band_centre_hz: Vec<f64>,
    /// Mean-square floor per band: quieter cells count as this level in both images, so
    /// leakage, and the recording's steady noise, do not dominate the compressive loudness
    /// scale. Empty: no floor.
    pub floor_mean_square: Vec<f64>,
    /// Loudness per band tabulated over dB above the floor (built by [`Self::with_floor_below`]).
    table: std::sync::Arc<Vec<f64>>,
    /// The band of each bin of the frames' spectrum (`fft_len = 2W`), built once.
    bin_band: std::sync::Arc<Vec<Option<usize>>>,
    /// `Σ hann²` of a frame.
    hann_power: f64,
}

/// Step of the loudness table, dB. Loudness is smooth in dB (about `e^(0.07·dB)` far above
/// threshold), so linear interpolation at this step errs by about 1e-5 relative.
const TABLE_STEP_DB: f64 = 0.05;
/// Range of the loudness table above the floor, dB.
const TABLE_RANGE_DB: f64 = 160.0;
const TABLE_LEN: usize = (TABLE_RANGE_DB / TABLE_STEP_DB) as usize + 1;

impl ImageGrid {
    /// The grid for `samples` samples at `sample_rate_hz`; `None` if shorter than one frame.
    pub fn new(sample_rate_hz: f64, samples: usize) -> Option<Self> {
        let window_len = ((0.023 * sample_rate_hz) as usize)
            .next_power_of_two()
            .max(64);
        if samples < window_len {
            return None;
        }
        let hop = window_len / 4;
        let frames = (samples - window_len) / hop + 1;
        let band_centre_hz = (0..BANDS).map(|b| inverse_bark(b as f64 + 0.5)).collect();
        let mut grid = Self {
            sample_rate_hz,
            window_len,
            hop,
            frames,
            band_centre_hz,
            floor_mean_square: Vec::new(),
            table: Default::default(),
            bin_band: Default::default(),
            hann_power: hann(window_len).iter().map(|v| v * v).sum(),
        };
        let bin_hz = sample_rate_hz / (2 * window_len) as f64;
        grid.bin_band = std::sync::Arc::new(
            (0..=window_len)
                .map(|k| grid.band_of(k as f64 * bin_hz))
                .collect(),
        );
        Some(grid)
    }

    /// The STFT layout of the grid's frames (`fft_len = 2W`, no cells: only its sizes are read).
    fn layout(&self) -> Spectrogram {
        Spectrogram {
            window_len: self.window_len,
            hop: self.hop,
            fft_len: 2 * self.window_len,
            frames: 0,
            bins: self.window_len + 1,
            sample_rate_hz: self.sample_rate_hz,
            data: Vec::new(),
        }
    }

    /// The band of bin `k` of a spectrum with `fft_len = 2W` (as [`Self::band_of`]).
    fn band_of_bin(&self, k: usize) -> Option<usize> {
        self.bin_band.get(k).copied().flatten()
    }

    /// The same grid with the floor set `below_db` under the loudest cell of `reference`, or
    /// per band at the recording's steady noise where that is higher: twice the band's 10th
    /// percentile over frames (a strike has decayed by then in all but the longest-ringing
    /// bands; a mode still ringing at the end keeps its decay above that level).
    pub fn with_floor_below(mut self, reference: &LoudnessImage, below_db: f64) -> Self {
        let max_ms = reference.mean_square.iter().copied().fold(0.0, f64::max);
        let global = max_ms * 10f64.powf(-below_db / 10.0);
        let frames = reference.mean_square.len() / BANDS;
        self.floor_mean_square = (0..BANDS)
            .map(|b| {
                let mut v: Vec<f64> = (0..frames)
                    .map(|m| reference.mean_square[m * BANDS + b])
                    .collect();
                let noise = if v.is_empty() {
                    0.0
                } else {
                    let i = v.len() / 10;
                    *v.select_nth_unstable_by(i, f64::total_cmp).1
                };
                global.max(2.0 * noise)
            })
            .collect();
        self.table = Default::default();
        if global > 0.0 {
            let mut t = Vec::with_capacity(BANDS * TABLE_LEN);
            for b in 0..BANDS {
                for i in 0..TABLE_LEN {
                    let ms =
                        self.floor_mean_square[b] * 10f64.powf(i as f64 * TABLE_STEP_DB / 10.0);
                    t.push(self.exact_loudness(b, ms));
                }
            }
            self.table = std::sync::Arc::new(t);
        }
        self
    }

    /// How long `mode` matters to an image on this grid: until it has decayed by 120 dB, or to
    /// 40 dB under its band's floor, where it can no longer move a cell (a cell is never quieter
    /// than the floor).
    pub fn audible_s(&self, mode: &DampedMode) -> f64 {
        let d = mode.damping_per_s.max(1e-9);
        let mut decay_s = 13.8 / d;
        let floor = self
            .band_of(mode.freq_hz)
            .and_then(|b| self.floor_mean_square.get(b))
            .copied()
            .unwrap_or(0.0);
        if floor > 0.0 {
            let ms0 = 0.5 * mode.amplitude * mode.amplitude;
            decay_s = decay_s.min((ms0 / (1e-4 * floor)).ln().max(0.0) / (2.0 * d));
        }
        decay_s
    }

    fn band_of(&self, freq_hz: f64) -> Option<usize> {
        let z = bark(freq_hz);
        (z >= 0.0 && freq_hz < 0.5 * self.sample_rate_hz).then(|| (z as usize).min(BANDS - 1))
    }

    fn loudness(&self, band: usize, mean_square: f64) -> f64 {
        if !self.table.is_empty() {
            let row = &self.table[band * TABLE_LEN..(band + 1) * TABLE_LEN];
            let floor = self.floor_mean_square[band];
            if mean_square <= floor {
                return row[0];
            }
            let x = 10.0 * (mean_square / floor).log10() / TABLE_STEP_DB;
            let i = x as usize;
            if i + 1 < TABLE_LEN {
                let t = x - i as f64;
                return row[i] + t * (row[i + 1] - row[i]);
            }
        }
        self.exact_loudness(band, mean_square)
    }

    fn exact_loudness(&self, band: usize, mean_square: f64) -> f64 {
        let floor = self.floor_mean_square.get(band).copied().unwrap_or(0.0);
        let mean_square = mean_square.max(floor);
        if !(mean_square > 0.0) {
            return 0.0;
        }
        // A full-scale sine has mean square 1/2.
        let spl = FULL_SCALE_DB_SPL + 10.0 * (2.0 * mean_square).log10();
        sone_for_phon(phon_for_spl(self.band_centre_hz[band], spl))
    }
}

/// Frequency (Hz) of critical-band rate `z` (bisection on [`bark`], which is increasing).
pub fn inverse_bark(z: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 40_000.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if bark(mid) < z {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// A loudness image: `data[frame * BANDS + band]` in sone.
#[derive(Clone, Debug, PartialEq)]
pub struct LoudnessImage {
    /// Layout.
    pub grid: ImageGrid,
    /// Cells, frame-major.
    pub data: Vec<f64>,
    /// The band mean squares the loudness came from.
    pub mean_square: Vec<f64>,
}

impl LoudnessImage {
    /// Eq. 19: the sum of squared cell differences. Images must share a grid.
    pub fn distance(&self, other: &LoudnessImage) -> f64 {
        debug_assert_eq!(self.grid, other.grid);
        self.data
            .iter()
            .zip(&other.data)
            .map(|(a, b)| (a - b) * (a - b))
            .sum()
    }
}

/// The image of a recorded (or synthesized) signal, sample 0 at the onset.
pub fn image_of_signal(x: &[f64], grid: &ImageGrid) -> LoudnessImage {
    let mut ms = vec![0.0; grid.frames * BANDS];
    if let Some(spec) = Spectrogram::compute(x, grid.sample_rate_hz, grid.window_len) {
        let scale = 2.0 / (spec.fft_len as f64 * grid.hann_power);
        let bands: Vec<Option<usize>> = if spec.fft_len == 2 * grid.window_len {
            (0..spec.bins).map(|k| grid.band_of_bin(k)).collect()
        } else {
            (0..spec.bins)
                .map(|k| grid.band_of(spec.bin_hz(k)))
                .collect()
        };
        for m in 0..grid.frames.min(spec.frames) {
            for (k, band) in bands.iter().enumerate().skip(1) {
                if let Some(b) = band {
                    ms[m * BANDS + b] += scale * spec.at(m, k).norm_sqr();
                }
            }
        }
    }
    finish(grid, ms)
}

/// The modes' signal over `samples` samples at the grid's rate, each mode only while it can
/// move a cell of `grid` ([`ImageGrid::audible_s`], where [`image_of_modes`] stops it too) and
/// one frame beyond: the synthesized route's input, at the cost of the modes' audible spans
/// instead of all of them times the whole recording.
pub fn audible_signal(modes: &[DampedMode], grid: &ImageGrid, samples: usize) -> Vec<f64> {
    let mut out = vec![0.0; samples];
    for m in modes {
        m.add_to(
            grid.sample_rate_hz,
            &mut out[..audible_samples(m, grid, samples)],
        );
    }
    out
}

/// Samples of `m` [`audible_signal`] synthesizes, at most `samples`.
pub fn audible_samples(m: &DampedMode, grid: &ImageGrid, samples: usize) -> usize {
    // A non-finite span (no damping) saturates to the whole recording.
    ((grid.audible_s(m) * grid.sample_rate_hz).ceil() as usize)
        .saturating_add(grid.window_len)
        .min(samples)
}

/// The image of a set of modes, computed analytically (see the module docs).
pub fn image_of_modes(modes: &[DampedMode], grid: &ImageGrid) -> LoudnessImage {
    // The STFT layout the reference image uses; only its sizes are read.
    let layout = grid.layout();
    // Complex cells of all modes together (coherent: overlapping modes interfere as they do in
    // the recording's STFT), each mode over the bins and frames where it matters. Bin-major, so
    // a mode's run of frames is contiguous; `used[k]` is the number of frames bin k has seen.
    let bins = layout.bins;
    WORKSPACE.with_borrow_mut(|cells| {
        if cells.len() < grid.frames * bins {
            *cells = vec![Complex64::new(0.0, 0.0); grid.frames * bins];
        }
        image_of_modes_in(modes, grid, &layout, cells, MIRROR_WIDTHS)
    })
}

/// How far (in widths of the bins kept around a mode) its mirror image at `−f` must be for the
/// conjugate term to be left out.
const MIRROR_WIDTHS: f64 = 3.0;

thread_local! {
    /// Complex cells reused between evaluations on one thread; all zero between calls.
    static WORKSPACE: std::cell::RefCell<Vec<Complex64>> = const { std::cell::RefCell::new(Vec::new()) };
}

fn image_of_modes_in(
    modes: &[DampedMode],
    grid: &ImageGrid,
    layout: &Spectrogram,
    cells: &mut [Complex64],
    mirror_widths: f64,
) -> LoudnessImage {
    let bins = layout.bins;
    let mut used = vec![0usize; bins];
    let bin_hz = layout.bin_width_hz();
    let frames_per_s = grid.sample_rate_hz / grid.hop as f64;
    for m in modes {
        if !(m.freq_hz > 0.0 && m.freq_hz < 0.5 * grid.sample_rate_hz && m.amplitude > 0.0) {
            continue;
        }
        let a = Complex64::from_polar(m.amplitude, m.phase_rad);
        let width = (16.0 + 8.0 * m.damping_per_s / std::f64::consts::TAU / bin_hz).min(600.0);
        let centre = m.freq_hz / bin_hz;
        let lo = (centre - width).max(1.0) as usize;
        let hi = ((centre + width) as usize).min(bins - 1);
        let last = grid
            .frames
            .min((grid.audible_s(m) * frames_per_s) as usize + 2);
        let columns = ModeColumns::new(layout, m.freq_hz, m.damping_per_s);
        if lo > hi {
            continue;
        }
        // The conjugate term peaks at −f (and at fs − f past Nyquist): from bins more than
        // three times the width already cut away from it, it is below that cut's leakage
        // (−90 dB or less for the Hann window), and left out.
        let mirror_bins = (lo as f64 + centre).min(layout.fft_len as f64 - hi as f64 - centre);
        if mirror_bins > mirror_widths * width {
            columns.for_each_positive_column(lo, hi, |k, [mut p, ps]| {
                for c in &mut cells[k * grid.frames..k * grid.frames + last] {
                    *c += a * p;
                    p *= ps;
                }
                used[k] = used[k].max(last);
            });
        } else {
            columns.for_each_column(lo, hi, |k, [mut p, mut q, ps, qs]| {
                for c in &mut cells[k * grid.frames..k * grid.frames + last] {
                    *c += a * p + a.conj() * q;
                    p *= ps;
                    q *= qs;
                }
                used[k] = used[k].max(last);
            });
        }
    }
    let scale = 2.0 / (layout.fft_len as f64 * grid.hann_power);
    let mut ms = vec![0.0; grid.frames * BANDS];
    for (k, &n) in used.iter().enumerate().skip(1) {
        if n == 0 {
            continue;
        }
        if let Some(b) = grid.band_of_bin(k) {
            for (frame, c) in cells[k * grid.frames..k * grid.frames + n]
                .iter()
                .enumerate()
            {
                ms[frame * BANDS + b] += scale * c.norm_sqr();
            }
        }
        cells[k * grid.frames..k * grid.frames + n].fill(Complex64::new(0.0, 0.0));
    }
    finish(grid, ms)
}

fn finish(grid: &ImageGrid, ms: Vec<f64>) -> LoudnessImage {
    let data = ms
        .iter()
        .enumerate()
        .map(|(i, &v)| grid.loudness(i % BANDS, v))
        .collect();
    LoudnessImage {
        grid: grid.clone(),
        data,
        mean_square: ms,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use resound_core::damped::synthesize;

    fn modes() -> Vec<DampedMode> {
        // Frequencies near band centres (3.5, 9.5, 15.5, 20.5 Bark).
        [3.5, 9.5, 15.5, 20.5]
            .iter()
            .zip([(6.0, 0.3), (20.0, 0.1), (60.0, 0.08), (150.0, 0.05)])
            .map(|(&z, (d, a))| DampedMode {
                freq_hz: inverse_bark(z),
                damping_per_s: d,
                amplitude: a,
                phase_rad: 0.4,
            })
            .collect()
    }

    #[test]
    fn analytic_image_matches_the_stft_image() {
        let fs = 44100.0;
        let m = modes();
        let x = synthesize(&m, fs, 22050);
        let grid = ImageGrid::new(fs, x.len()).unwrap();
        let s = image_of_signal(&x, &grid);
        let grid = grid.with_floor_below(&s, 40.0);
        let s = image_of_signal(&x, &grid);
        let a = image_of_modes(&m, &grid);
        let norm: f64 = s.data.iter().map(|v| v * v).sum();
        let rel = (a.distance(&s) / norm).sqrt();

        assert!(rel < 1e-3, "relative difference {rel}");
        // And the metric sees a 6 dB change of one mode.
        let mut louder = m.clone();
        louder[1].amplitude *= 2.0;
        let b = image_of_modes(&louder, &grid);
        assert!(b.distance(&s) > 10.0 * a.distance(&s));
    }

    #[test]
    fn leaving_out_far_mirror_terms_changes_no_band_level_by_more_than_1e_6() {
        // Modes from 30 Hz to 21 kHz, d 0.5–900: near DC and Nyquist the mirror term is kept,
        // elsewhere left out.
        let fs = 44100.0;
        let m: Vec<DampedMode> = [
            (30.0, 0.5),
            (95.0, 40.0),
            (440.0, 3.0),
            (2500.0, 900.0),
            (7000.0, 20.0),
            (15000.0, 200.0),
            (21000.0, 5.0),
        ]
        .iter()
        .map(|&(f, d)| DampedMode {
            freq_hz: f,
            damping_per_s: d,
            amplitude: 0.1,
            phase_rad: 0.7,
        })
        .collect();
        let grid = ImageGrid::new(fs, 44100).unwrap();
        let layout = grid.layout();
        let mut cells = vec![Complex64::new(0.0, 0.0); grid.frames * layout.bins];
        let exact = image_of_modes_in(&m, &grid, &layout, &mut cells, f64::INFINITY);
        let fast = image_of_modes_in(&m, &grid, &layout, &mut cells, MIRROR_WIDTHS);
        let peak = exact.mean_square.iter().copied().fold(0.0, f64::max);
        let mut differ = 0;
        for (a, b) in exact.mean_square.iter().zip(&fast.mean_square) {
            // Every cell within 120 dB of the loudest, to 1e-6 of itself.
            if *a > 1e-12 * peak {
                assert!((a - b).abs() <= 1e-6 * a, "{a} vs {b}");
            }
            differ += usize::from(a != b);
        }
        // The fast path was taken (cells differ in the last bits).
        assert!(differ > 0);
    }

    #[test]
    fn stopping_each_mode_where_it_no_longer_moves_a_cell_keeps_the_image() {
        // The test modes, and a quiet long-ringing one that outlasts the recording.
        let fs = 44100.0;
        let n = 44100;
        let mut m = modes();
        m.push(DampedMode {
            freq_hz: 3000.0,
            damping_per_s: 0.5,
            amplitude: 0.01,
            phase_rad: 0.0,
        });
        let full = synthesize(&m, fs, n);
        let grid = ImageGrid::new(fs, n).unwrap();
        let grid = grid
            .clone()
            .with_floor_below(&image_of_signal(&full, &grid), 50.0);
        let cut = audible_signal(&m, &grid, n);
        // The heavily damped modes stop early (the sum covers far less than every mode over
        // the whole recording), the long-ringing one runs to the end.
        let spans: Vec<usize> = m.iter().map(|x| audible_samples(x, &grid, n)).collect();
        assert!(spans[3] < n / 10 && spans[4] == n, "{spans:?}");
        assert!(full.iter().zip(&cut).any(|(a, b)| a != b));
        let (a, b) = (image_of_signal(&full, &grid), image_of_signal(&cut, &grid));
        let norm: f64 = a.data.iter().map(|v| v * v).sum();
        assert!(a.distance(&b) < 1e-8 * norm, "{} of {norm}", a.distance(&b));
    }

    #[test]
    fn grid_and_bark_inverse() {
        assert!((bark(inverse_bark(8.5)) - 8.5).abs() < 1e-9);
        let g = ImageGrid::new(48000.0, 48000).unwrap();
        assert_eq!(g.window_len, 2048);
        assert_eq!(g.frames, (48000 - 2048) / 512 + 1);
        assert!(ImageGrid::new(48000.0, 100).is_none());
        // Silence is silent; a loud tone is several sone.
        let quiet = image_of_modes(&[], &g);
        assert!(quiet.data.iter().all(|&v| v == 0.0));
        let tone = image_of_modes(&[DampedMode::new(1000.0, 1.0, 0.5)], &g);
        let peak = tone.data.iter().copied().fold(0.0, f64::max);
        assert!(peak > 10.0 && peak < 200.0, "{peak}");
    }
}
