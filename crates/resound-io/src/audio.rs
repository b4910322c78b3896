//! Audio in (WAV, FLAC, OGG Vorbis, MP3 via Symphonia) and out (WAV via hound, atomically).

use crate::{atomic::write_atomic, io_err, parse_err, Result};
use std::path::Path;
use symphonia::core::audio::SampleBuffer;
use symphonia::core::codecs::{DecoderOptions, CODEC_TYPE_NULL};
use symphonia::core::errors::Error as SymError;
use symphonia::core::formats::FormatOptions;
use symphonia::core::io::MediaSourceStream;
use symphonia::core::meta::MetadataOptions;
use symphonia::core::probe::Hint;

/// Decoded audio: one `Vec` per channel, full scale = 1.0.
#[derive(Clone, Debug)]
pub struct AudioClip {
    /// Sample rate in Hz.
    pub sample_rate_hz: u32,
    /// Samples per channel.
    pub channels: Vec<Vec<f32>>,
    /// Codec name, e.g. "pcm_f32le", "flac", "vorbis", "mp3".
    pub codec: String,
}

impl AudioClip {
    /// Frames (samples per channel).
    pub fn frames(&self) -> usize {
        self.channels.first().map_or(0, Vec::len)
    }

    /// Duration in seconds.
    pub fn duration_s(&self) -> f64 {
        self.frames() as f64 / f64::from(self.sample_rate_hz)
    }

    /// One channel (`Some(i)`, 0-based) or the mean of all channels (`None`), as `f64`.
    ///
    /// # Errors
    /// [`crate::IoError::Parse`] when the channel does not exist.
    pub fn mono(&self, channel: Option<usize>, path: &Path) -> Result<Vec<f64>> {
        match channel {
            Some(c) => self
                .channels
                .get(c)
                .map(|ch| ch.iter().map(|&v| f64::from(v)).collect())
                .ok_or_else(|| {
                    parse_err(
                        path,
                        format!(
                            "channel {} requested but the file has {} channel(s) (channels count from 1)",
                            c + 1,
                            self.channels.len()
                        ),
                    )
                }),
            None => {
                let n = self.channels.len().max(1) as f64;
                Ok((0..self.frames())
                    .map(|i| self.channels.iter().map(|ch| f64::from(ch[i])).sum::<f64>() / n)
                    .collect())
            }
        }
    }
}

/// Symphonia 0.5 panics on a WAV whose `fmt ` chunk says 0 Hz or 0 channels (it builds a time
/// base from them before any check): read those two fields first and refuse such files.
/// Anything that is not RIFF/WAVE, or too short to tell, is left to the decoder.
fn check_wav_header(mut file: &std::fs::File, path: &Path) -> Result<()> {
    use std::io::{Read, Seek, SeekFrom};
    // Symphonia's probe looks for a format marker anywhere in the first MiB, so every RIFF/WAVE
    // header there is checked, not only one at offset 0 (fuzzing found "\0RIFF…").
    const PROBE: usize = (1 << 20) + 4096;
    let mut head = Vec::new();
    file.take(PROBE as u64)
        .read_to_end(&mut head)
        .map_err(|e| io_err(path, e))?;
    file.seek(SeekFrom::Start(0)).map_err(|e| io_err(path, e))?;
    let starts: Vec<usize> = head
        .windows(12)
        .enumerate()
        .filter(|(_, w)| &w[..4] == b"RIFF" && &w[8..12] == b"WAVE")
        .map(|(i, _)| i)
        .collect();
    for start in starts {
        check_riff_chunks(&head[start..], path)?;
    }
    let flacs: Vec<usize> = head
        .windows(4)
        .enumerate()
        .filter(|(_, w)| *w == b"fLaC")
        .map(|(i, _)| i)
        .collect();
    for start in flacs {
        check_flac_metadata(&head[start + 4..], path)?;
    }
    // Vorbis comment headers (OGG Vorbis): Symphonia allocates each length it reads, so none
    // may exceed what the file holds after it.
    let file_len = file.metadata().map_or(head.len() as u64, |m| m.len()) as usize;
    let vorbis: Vec<usize> = head
        .windows(7)
        .enumerate()
        .filter(|(_, w)| *w == b"\x03vorbis")
        .map(|(i, _)| i + 7)
        .collect();
    for start in vorbis {
        let rest = file_len.saturating_sub(start);
        let le = |at: usize| -> Option<usize> {
            head.get(start + at..start + at + 4)
                .map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]) as usize)
        };
        let fits = (|| {
            let mut at = 4usize.checked_add(le(0)?)?;
            if at > rest {
                return None;
            }
            let n = le(at)?;
            if n > rest / 4 {
                return None;
            }
            at += 4;
            for _ in 0..n {
                let Some(l) = le(at) else { return Some(()) }; // beyond what was read: trust it
                at = at.checked_add(4)?.checked_add(l)?;
                if at > rest {
                    return None;
                }
            }
            Some(())
        })();
        if fits.is_none() {
            return Err(parse_err(
                path,
                "Vorbis comment header: a length runs past the end of the file",
            ));
        }
    }
    Ok(())
}

/// FLAC metadata blocks after a `fLaC` marker: the length fields inside picture and comment
/// blocks must fit in the block. Symphonia allocates each of them before reading (fuzzing found
/// 2–4 GiB allocations from files under 1 KiB).
fn check_flac_metadata(mut blocks: &[u8], path: &Path) -> Result<()> {
    let be = |b: &[u8], at: usize| -> Option<usize> {
        b.get(at..at + 4)
            .map(|s| u32::from_be_bytes([s[0], s[1], s[2], s[3]]) as usize)
    };
    while blocks.len() >= 4 {
        let (flags, len) = (
            blocks[0],
            usize::from(blocks[1]) << 16 | usize::from(blocks[2]) << 8 | usize::from(blocks[3]),
        );
        let body = &blocks[4..];
        let block = &body[..len.min(body.len())];
        if flags & 0x7f == 6 {
            // type, media type length, media type, description length, description, 4 × u32,
            // data length, data.
            let fits = (|| {
                let mime = be(block, 4)?;
                let desc_at = 8usize.checked_add(mime)?;
                let desc = be(block, desc_at)?;
                let data_at = desc_at.checked_add(4)?.checked_add(desc)?.checked_add(16)?;
                let data = be(block, data_at)?;
                (data_at.checked_add(4)?.checked_add(data)? <= len).then_some(())
            })();
            if fits.is_none() {
                return Err(parse_err(
                    path,
                    format!(
                        "FLAC metadata: a picture block's lengths do not fit in its {len} bytes"
                    ),
                ));
            }
        }
        if flags & 0x7f == 4 {
            // Vorbis comments (little-endian): vendor length, vendor, count, (length, text)*.
            let le = |at: usize| -> Option<usize> {
                block
                    .get(at..at + 4)
                    .map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]) as usize)
            };
            let fits = (|| {
                let mut at = 4usize.checked_add(le(0)?)?;
                let n = le(at)?;
                at = at.checked_add(4)?;
                for _ in 0..n.min(len / 4 + 1) {
                    let l = le(at)?;
                    at = at.checked_add(4)?.checked_add(l)?;
                    if at > len {
                        return None;
                    }
                }
                (at <= len && n <= len / 4).then_some(())
            })();
            if fits.is_none() {
                return Err(parse_err(
                    path,
                    format!(
                        "FLAC metadata: a comment block's lengths do not fit in its {len} bytes"
                    ),
                ));
            }
        }
        if flags & 0x80 != 0 || len > body.len() {
            break;
        }
        blocks = &body[len..];
    }
    Ok(())
}

/// The chunk walk of [`check_wav_header`] from one `RIFF….WAVE` header.
fn check_riff_chunks(head: &[u8], path: &Path) -> Result<()> {
    let mut at = 12;
    while at + 8 <= head.len() {
        let id = &head[at..at + 4];
        let len =
            u32::from_le_bytes([head[at + 4], head[at + 5], head[at + 6], head[at + 7]]) as usize;
        if id == b"fmt " {
            let f = &head[at + 8..];
            if f.len() < 8 {
                return Ok(());
            }
            let channels = u16::from_le_bytes([f[2], f[3]]);
            let rate = u32::from_le_bytes([f[4], f[5], f[6], f[7]]);
            if channels == 0 || rate == 0 {
                return Err(parse_err(
                    path,
                    format!(
                        "WAV header: {rate} Hz, {channels} channel(s) — not a usable recording"
                    ),
                ));
            }
            if channels > 32 {
                return Err(parse_err(
                    path,
                    format!("WAV header: {channels} channels (at most 32 are supported)"),
                ));
            }
            // WAVE_FORMAT_EXTENSIBLE: Symphonia pads a channel mask with too few bits above its
            // highest one, which overflows (a panic in debug builds, found by fuzzing) when the
            // padded mask needs more than 32 bits.
            let format = u16::from_le_bytes([f[0], f[1]]);
            if format == 0xFFFE && f.len() >= 24 {
                let mask = u32::from_le_bytes([f[20], f[21], f[22], f[23]]);
                let missing = i64::from(channels) - i64::from(mask.count_ones());
                let bits = 32 - i64::from(mask.leading_zeros());
                if missing > 0 && bits + missing > 32 {
                    return Err(parse_err(
                        path,
                        format!(
                            "WAV header: channel mask {mask:#010x} names {} of {channels} channels \
                             and cannot be completed",
                            mask.count_ones()
                        ),
                    ));
                }
            }
            return Ok(());
        }
        at += 8 + len + (len & 1);
    }
    Ok(())
}

/// Decodes an audio file (WAV PCM 8/16/24/32 and float 32/64, FLAC, OGG Vorbis, MP3).
///
/// # Errors
/// [`crate::IoError::Io`] when the file cannot be read; [`crate::IoError::Unsupported`]-style parse errors for
/// unknown formats; [`crate::IoError::Parse`] for corrupt or truncated data and files with no samples.
pub fn load_audio(path: &Path) -> Result<AudioClip> {
    let file = std::fs::File::open(path).map_err(|e| io_err(path, e))?;
    check_wav_header(&file, path)?;
    let mss = MediaSourceStream::new(Box::new(file), Default::default());
    let mut hint = Hint::new();
    if let Some(ext) = path.extension().and_then(|e| e.to_str()) {
        hint.with_extension(ext);
    }
    let probed = symphonia::default::get_probe()
        .format(
            &hint,
            mss,
            &FormatOptions::default(),
            &MetadataOptions::default(),
        )
        .map_err(|e| match e {
            SymError::IoError(io) if io.kind() != std::io::ErrorKind::UnexpectedEof => {
                io_err(path, io)
            }
            SymError::Unsupported(_) | SymError::IoError(_) => parse_err(
                path,
                "not a supported audio file (supported: WAV, FLAC, OGG Vorbis, MP3)",
            ),
            other => parse_err(path, format!("cannot read the audio container: {other}")),
        })?;
    let mut format = probed.format;
    let track = format
        .tracks()
        .iter()
        .find(|t| t.codec_params.codec != CODEC_TYPE_NULL)
        .ok_or_else(|| parse_err(path, "the file holds no audio track"))?;
    let track_id = track.id;
    let expected_frames = track.codec_params.n_frames;
    let codec = symphonia::default::get_codecs()
        .get_codec(track.codec_params.codec)
        .map_or_else(|| "unknown".to_string(), |d| d.short_name.to_string());
    let mut decoder = symphonia::default::get_codecs()
        .make(&track.codec_params, &DecoderOptions::default())
        .map_err(|e| parse_err(path, format!("unsupported codec: {e}")))?;
    let mut sample_rate = track.codec_params.sample_rate.unwrap_or(0);
    let mut channels: Vec<Vec<f32>> = Vec::new();
    let mut buf: Option<SampleBuffer<f32>> = None;
    let mut truncated = false;
    loop {
        let packet = match format.next_packet() {
            Ok(p) => p,
            Err(SymError::IoError(e)) if e.kind() == std::io::ErrorKind::UnexpectedEof => break,
            Err(SymError::ResetRequired) => break,
            Err(e) => return Err(parse_err(path, format!("corrupt audio stream: {e}"))),
        };
        if packet.track_id() != track_id {
            continue;
        }
        match decoder.decode(&packet) {
            Ok(decoded) => {
                let spec = *decoded.spec();
                sample_rate = spec.rate;
                let nch = spec.channels.count();
                if channels.is_empty() {
                    channels = vec![Vec::new(); nch];
                }
                if nch != channels.len() {
                    return Err(parse_err(
                        path,
                        "the channel count changes inside the stream",
                    ));
                }
                let need = decoded.capacity() as u64;
                let b = match &mut buf {
                    Some(b) if b.capacity() as u64 >= need => b,
                    _ => buf.insert(SampleBuffer::<f32>::new(need, spec)),
                };
                b.copy_interleaved_ref(decoded);
                for (i, v) in b.samples().iter().enumerate() {
                    channels[i % nch].push(*v);
                }
            }
            Err(SymError::DecodeError(e)) => {
                return Err(parse_err(path, format!("corrupt audio data: {e}")));
            }
            Err(SymError::IoError(e)) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
                truncated = true;
                break;
            }
            Err(e) => return Err(parse_err(path, format!("cannot decode the audio: {e}"))),
        }
    }
    let frames = channels.first().map_or(0, Vec::len);
    if frames == 0 {
        return Err(parse_err(path, "the file holds no audio samples"));
    }
    if let Some(n) = expected_frames {
        // Lossy codecs may pad or trim by up to a frame; PCM must match.
        if truncated || (frames as u64) + 4096 < n {
            return Err(parse_err(
                path,
                format!("the file is truncated: its header promises {n} frames, only {frames} are present"),
            ));
        }
    }
    if !(1000..=768_000).contains(&sample_rate) {
        return Err(parse_err(
            path,
            format!("implausible sample rate {sample_rate} Hz"),
        ));
    }
    if let Some(i) = channels.iter().flatten().position(|v| !v.is_finite()) {
        return Err(parse_err(
            path,
            format!("non-finite sample (NaN or infinity) at index {i}"),
        ));
    }
    Ok(AudioClip {
        sample_rate_hz: sample_rate,
        channels,
        codec,
    })
}

/// Sample format of written WAV files (named `pcm16`, `pcm24`, `float`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WavFormat {
    /// 16-bit PCM (rounded without dither, clipped to full scale).
    Pcm16,
    /// 24-bit PCM.
    Pcm24,
    /// 32-bit IEEE float.
    #[serde(rename = "float", alias = "float32")]
    Float32,
}

/// Writes mono `samples` as a WAV file, atomically (temporary file, then rename).
///
/// # Errors
/// [`crate::IoError::Io`] from the file system; [`crate::IoError::Parse`] for a zero sample rate or
/// non-finite samples (nothing is written).
pub fn write_wav(
    path: &Path,
    samples: &[f32],
    sample_rate_hz: u32,
    format: WavFormat,
) -> Result<()> {
    write_wav_channels(path, &[samples], sample_rate_hz, format)
}

/// Writes equally long `channels` (interleaved in the file) as a WAV file, atomically.
///
/// # Errors
/// As [`write_wav`]; also for no channels or channels of different lengths.
pub fn write_wav_channels(
    path: &Path,
    channels: &[&[f32]],
    sample_rate_hz: u32,
    format: WavFormat,
) -> Result<()> {
    let Some(first) = channels.first() else {
        return Err(parse_err(path, "no channels to write"));
    };
    if channels.len() > 16 || channels.iter().any(|c| c.len() != first.len()) {
        return Err(parse_err(path, "channels must be 1–16 of equal length"));
    }
    let frames = first.len();
    let samples: Vec<f32> = (0..frames)
        .flat_map(|i| channels.iter().map(move |c| c[i]))
        .collect();
    let samples = &samples[..];
    if sample_rate_hz == 0 {
        return Err(parse_err(path, "sample rate must be positive"));
    }
    if let Some(i) = samples.iter().position(|v| !v.is_finite()) {
        return Err(parse_err(
            path,
            format!("refusing to write non-finite sample at index {i}"),
        ));
    }
    let (bits, fmt) = match format {
        WavFormat::Pcm16 => (16, hound::SampleFormat::Int),
        WavFormat::Pcm24 => (24, hound::SampleFormat::Int),
        WavFormat::Float32 => (32, hound::SampleFormat::Float),
    };
    let spec = hound::WavSpec {
        channels: channels.len() as u16,
        sample_rate: sample_rate_hz,
        bits_per_sample: bits,
        sample_format: fmt,
    };
    let mut cursor = std::io::Cursor::new(Vec::with_capacity(samples.len() * 4 + 64));
    {
        let to_io = |e: hound::Error| io_err(path, std::io::Error::other(e.to_string()));
        let mut w = hound::WavWriter::new(&mut cursor, spec).map_err(to_io)?;
        match format {
            WavFormat::Float32 => {
                for &v in samples {
                    w.write_sample(v).map_err(to_io)?;
                }
            }
            WavFormat::Pcm16 | WavFormat::Pcm24 => {
                // Full scale is 2^(bits−1), as decoders divide by it; +1.0 clips to the top code.
                let full = f64::from(1i32 << (bits - 1));
                for &v in samples {
                    let q = (f64::from(v) * full).round().clamp(-full, full - 1.0) as i32;
                    w.write_sample(q).map_err(to_io)?;
                }
            }
        }
        w.finalize().map_err(to_io)?;
    }
    let bytes = cursor.into_inner();
    write_atomic(path, |w| w.write_all(&bytes))
}
