//! Narration with kira. Without an audio device the kiosk runs silently and says so once in the
//! log; it still decodes each narration with kira, so a broken file is reported the same way.
//! (kira's mock backend is no substitute here: its clock only advances when driven, so every
//! sound played on it stays in memory — a soak run showed it.)

use kira::sound::static_sound::{StaticSoundData, StaticSoundHandle};
use kira::{AudioManager, AudioManagerSettings, Decibels, DefaultBackend, Tween};
use std::collections::HashSet;
use std::path::{Path, PathBuf};

enum Manager {
    Device(Box<AudioManager<DefaultBackend>>),
    /// No device: narrations are decoded (to report broken files) and dropped.
    Silent,
}

/// Decodes a narration file completely (WAV with PCM, Ogg Vorbis, MP3, FLAC), as the kiosk and
/// the authoring tool play it; the error names the file.
pub fn decode(path: &Path) -> Result<StaticSoundData, String> {
    let unplayable = |e: String| {
        format!(
            "narration {}: not a sound the kiosk can play (WAV with PCM, Ogg Vorbis, MP3 or FLAC): {e}; the node \
             is shown without it",
            path.display()
        )
    };
    let data = StaticSoundData::from_file(path).map_err(|e| unplayable(e.to_string()))?;
    // A header can say anything: a rate of 0 would make its length infinite (and the player
    // divide by it).
    if data.sample_rate == 0 {
        return Err(unplayable("its header gives a sample rate of 0".into()));
    }
    Ok(data)
}

/// Plays one narration at a time.
pub struct Narrator {
    manager: Manager,
    playing: Option<StaticSoundHandle>,
    /// Files already reported as broken (logged once each).
    reported: HashSet<PathBuf>,
    /// What is playing (for the log and tests).
    pub current: Option<PathBuf>,
}

fn decibels(volume: f64) -> Decibels {
    if volume <= 0.0 { Decibels::SILENCE } else { Decibels((20.0 * volume.log10()) as f32) }
}

impl Narrator {
    /// Opens the default audio device, or the silent backend when there is none (`silent` forces
    /// it, e.g. for tests).
    pub fn new(volume: f64, silent: bool) -> Self {
        let device = if silent {
            Err("silent mode requested".to_string())
        } else {
            AudioManager::<DefaultBackend>::new(AudioManagerSettings::default()).map_err(|e| e.to_string())
        };
        let mut manager = match device {
            Ok(m) => Manager::Device(Box::new(m)),
            Err(e) => {
                tracing::warn!("no audio device ({e}): narration is silent, captions still show");
                Manager::Silent
            }
        };
        let db = decibels(volume);
        match &mut manager {
            Manager::Device(m) => m.main_track().set_volume(db, Tween::default()),
            Manager::Silent => {}
        }
        Self { manager, playing: None, reported: HashSet::new(), current: None }
    }

    /// Whether sound actually reaches a device.
    pub fn audible(&self) -> bool {
        matches!(self.manager, Manager::Device(_))
    }

    /// Plays a file (stopping the previous narration). A missing or broken file is logged once
    /// and the kiosk goes on without it; the error is returned for callers that show it (the
    /// authoring tool).
    pub fn play(&mut self, path: &Path) -> Result<(), String> {
        self.stop();
        let data = match decode(path) {
            Ok(d) => d,
            Err(e) => {
                if self.reported.insert(path.to_path_buf()) {
                    tracing::warn!("{e}; skipped");
                }
                return Err(e);
            }
        };
        let handle = match &mut self.manager {
            Manager::Device(m) => m.play(data).map_err(|e| e.to_string()),
            Manager::Silent => {
                self.current = Some(path.to_path_buf());
                return Ok(());
            }
        };
        match handle {
            Ok(h) => {
                self.playing = Some(h);
                self.current = Some(path.to_path_buf());
                Ok(())
            }
            Err(e) => {
                let e = format!("narration {}: cannot play: {e}", path.display());
                tracing::warn!("{e}");
                Err(e)
            }
        }
    }

    /// Plays a file through the device and waits until it has been played to its end (the
    /// `sound-check` command); returns its length in seconds. Without a device this is an error.
    pub fn play_to_end(&mut self, path: &Path) -> Result<f64, String> {
        if !self.audible() {
            return Err(format!("narration {}: no audio device", path.display()));
        }
        let seconds = decode(path)?.duration().as_secs_f64();
        self.play(path)?;
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs_f64(seconds + 10.0);
        while self.playing.as_ref().is_some_and(|h| h.state() != kira::sound::PlaybackState::Stopped) {
            if std::time::Instant::now() > deadline {
                self.stop();
                return Err(format!(
                    "narration {}: still playing {:.0} s after its end; the audio device does not take sound",
                    path.display(),
                    10.0
                ));
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        self.playing = None;
        self.current = None;
        Ok(seconds)
    }

    /// Stops the narration with a short fade.
    pub fn stop(&mut self) {
        if let Some(mut h) = self.playing.take() {
            h.stop(Tween { duration: std::time::Duration::from_millis(300), ..Default::default() });
        }
        self.current = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 16-bit mono PCM WAV of `samples` zeros whose header gives `rate`.
    fn wav(rate: u32, samples: u32) -> Vec<u8> {
        let data = samples * 2;
        let mut b = Vec::new();
        b.extend_from_slice(b"RIFF");
        b.extend_from_slice(&(36 + data).to_le_bytes());
        b.extend_from_slice(b"WAVEfmt ");
        b.extend_from_slice(&16u32.to_le_bytes());
        b.extend_from_slice(&1u16.to_le_bytes());
        b.extend_from_slice(&1u16.to_le_bytes());
        b.extend_from_slice(&rate.to_le_bytes());
        b.extend_from_slice(&(rate * 2).to_le_bytes());
        b.extend_from_slice(&2u16.to_le_bytes());
        b.extend_from_slice(&16u16.to_le_bytes());
        b.extend_from_slice(b"data");
        b.extend_from_slice(&data.to_le_bytes());
        b.resize(b.len() + data as usize, 0);
        b
    }

    #[test]
    fn a_wav_whose_header_gives_no_sample_rate_is_refused_not_played() {
        let dir = tempfile::tempdir().expect("temp dir");
        let good = dir.path().join("good.wav");
        std::fs::write(&good, wav(8000, 800)).expect("write");
        let d = decode(&good).expect("a good WAV");
        assert!((d.duration().as_secs_f64() - 0.1).abs() < 1e-9);
        let bad = dir.path().join("rate0.wav");
        std::fs::write(&bad, wav(0, 800)).expect("write");
        let e = decode(&bad).expect_err("refused");
        assert!(e.contains("rate0.wav") && e.contains("sample rate of 0"), "{e}");
    }
}
