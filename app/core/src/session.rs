//! The touch-session format: JSON Lines, an optional header object with
//! `"session"` (format version 1), then one touch event per line. Unknown keys are ignored;
//! a malformed line is an error naming its line number. The kiosk records visitors in the same
//! format, so a museum's real session replays in a test.

use crate::gesture::{TouchEvent, TouchKind};
use serde::{Deserialize, Serialize};

/// The session format version this build reads and writes.
pub const SESSION_VERSION: u32 = 1;

/// Latest event time of a session, in seconds (24 hours: a kiosk's day and more).
pub const MAX_SESSION_SECS: f64 = 86_400.0;

/// The optional first line.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SessionHeader {
    /// Format version.
    pub session: u32,
    /// Exhibit the session was recorded on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exhibit: Option<String>,
    /// Seed of the recommender when recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
}

/// A parsed session.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Session {
    /// The header, if present.
    pub header: Option<SessionHeader>,
    /// Events in time order.
    pub events: Vec<TouchEvent>,
}

/// Why a session cannot be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("line {line}: {msg}")]
pub struct SessionError {
    /// 1-based line.
    pub line: usize,
    /// What is wrong.
    pub msg: String,
}

#[derive(Deserialize)]
struct RawEvent {
    t: f64,
    ev: TouchKind,
    id: i64,
    x: f64,
    y: f64,
}

impl Session {
    /// Parses a session file's text.
    pub fn parse(text: &str) -> Result<Self, SessionError> {
        let mut s = Session::default();
        let mut last_t = f64::NEG_INFINITY;
        for (i, line) in text.lines().enumerate() {
            let n = i + 1;
            let line = line.trim();
            if line.is_empty() {
                continue;
            }
            let err = |msg: String| SessionError { line: n, msg };
            let value: serde_json::Value =
                serde_json::from_str(line).map_err(|e| err(format!("not a JSON object: {e}")))?;
            if value.get("session").is_some() {
                if s.header.is_some() || !s.events.is_empty() {
                    return Err(err("a session header may only be the first line".into()));
                }
                let h: SessionHeader =
                    serde_json::from_value(value).map_err(|e| err(format!("bad header: {e}")))?;
                if h.session != SESSION_VERSION {
                    return Err(err(format!(
                        "session format {} (this build reads {SESSION_VERSION})",
                        h.session
                    )));
                }
                s.header = Some(h);
                continue;
            }
            let e: RawEvent = serde_json::from_value(value).map_err(|e| err(format!("bad event: {e}")))?;
            if !(e.t.is_finite() && e.t >= 0.0) {
                return Err(err(format!("time {} is not a non-negative number", e.t)));
            }
            if e.t > MAX_SESSION_SECS {
                return Err(err(format!(
                    "time {} s is beyond the longest session, {MAX_SESSION_SECS} s (24 hours)",
                    e.t
                )));
            }
            if e.t < last_t {
                return Err(err(format!("time {} goes back (previous event at {last_t})", e.t)));
            }
            last_t = e.t;
            s.events.push(TouchEvent { t: e.t, ev: e.ev, id: e.id, x: e.x, y: e.y });
        }
        Ok(s)
    }

    /// Writes the session in its file format.
    pub fn to_jsonl(&self) -> String {
        let mut out = String::new();
        if let Some(h) = &self.header {
            out.push_str(&serde_json::to_string(h).unwrap_or_default());
            out.push('\n');
        }
        for e in &self.events {
            out.push_str(&serde_json::to_string(e).unwrap_or_default());
            out.push('\n');
        }
        out
    }

    /// Time of the last event.
    pub fn duration(&self) -> f64 {
        self.events.last().map_or(0.0, |e| e.t)
    }
}

/// A finger's path in a drag: (id, from, to), positions normalised to the surface.
pub type Path = (i64, (f64, f64), (f64, f64));

/// A touch script, written like a choreography: tests, benchmarks and the demo write sessions
/// with it.
#[derive(Default, Clone, Debug)]
pub struct Script {
    /// Current time of the script.
    pub t: f64,
    /// Events so far.
    pub events: Vec<TouchEvent>,
}

impl Script {
    /// An empty script at t = 0.
    pub fn new() -> Self {
        Self::default()
    }
    fn push(&mut self, ev: TouchKind, id: i64, x: f64, y: f64) {
        self.events.push(TouchEvent { t: self.t, ev, id, x, y });
    }
    /// A finger lands.
    pub fn down(mut self, id: i64, x: f64, y: f64) -> Self {
        self.push(TouchKind::Down, id, x, y);
        self
    }
    /// A finger lifts.
    pub fn up(mut self, id: i64, x: f64, y: f64) -> Self {
        self.push(TouchKind::Up, id, x, y);
        self
    }
    /// The system cancels a touch.
    pub fn cancel(mut self, id: i64) -> Self {
        self.push(TouchKind::Cancel, id, 0.5, 0.5);
        self
    }
    /// The mouse's right button at `(x, y)`: the radial menu opens there, or closes.
    pub fn menu(mut self, x: f64, y: f64) -> Self {
        self.push(TouchKind::Menu, 0, x, y);
        self
    }
    /// Time passes.
    pub fn wait(mut self, secs: f64) -> Self {
        self.t += secs;
        self
    }
    /// Moves fingers linearly from `from` to `to` over `secs`, one event per finger every 16 ms.
    pub fn drag(mut self, fingers: &[Path], secs: f64) -> Self {
        let n = (secs / 0.016).ceil().max(1.0) as usize;
        let t0 = self.t;
        for k in 1..=n {
            let s = k as f64 / n as f64;
            self.t = t0 + secs * s;
            for &(id, a, b) in fingers {
                self.push(TouchKind::Move, id, a.0 + (b.0 - a.0) * s, a.1 + (b.1 - a.1) * s);
            }
        }
        self
    }
    /// A tap: down and up at one point 50 ms apart.
    pub fn tap(self, id: i64, x: f64, y: f64) -> Self {
        self.down(id, x, y).wait(0.05).up(id, x, y)
    }
    /// A radial-menu pick: a long press at `at` held `hold` seconds, then a 0.2 s slide to `to`
    /// and release there (selects in that direction).
    pub fn radial_pick(self, id: i64, at: (f64, f64), hold: f64, to: (f64, f64)) -> Self {
        self.down(id, at.0, at.1).wait(hold).drag(&[(id, at, to)], 0.2).up(id, to.0, to.1)
    }
    /// One finger: down at `from`, slide to `to` over `secs`, up (a swipe or a drag).
    pub fn swipe(self, id: i64, from: (f64, f64), to: (f64, f64), secs: f64) -> Self {
        self.down(id, from.0, from.1).drag(&[(id, from, to)], secs).up(id, to.0, to.1)
    }
    /// One finger: down at the centre, push to `offset` quickly, hold for `secs` (joystick), up.
    pub fn joystick(self, id: i64, offset: (f64, f64), secs: f64) -> Self {
        let end = (0.5 + offset.0, 0.5 + offset.1);
        self.down(id, 0.5, 0.5).drag(&[(id, (0.5, 0.5), end)], 0.1).wait(secs).up(id, end.0, end.1)
    }
    /// Two-finger pinch: the fingers' distance goes from `d0` to `d1` (screen heights).
    pub fn pinch(self, d0: f64, d1: f64, secs: f64) -> Self {
        let a0 = (0.5 - d0 / 2.0 / (16.0 / 9.0), 0.5);
        let b0 = (0.5 + d0 / 2.0 / (16.0 / 9.0), 0.5);
        let a1 = (0.5 - d1 / 2.0 / (16.0 / 9.0), 0.5);
        let b1 = (0.5 + d1 / 2.0 / (16.0 / 9.0), 0.5);
        self.down(1, a0.0, a0.1)
            .down(2, b0.0, b0.1)
            .drag(&[(1, a0, a1), (2, b0, b1)], secs)
            .up(1, a1.0, a1.1)
            .up(2, b1.0, b1.1)
    }
    /// The session (events sorted by time).
    pub fn session(&self) -> Session {
        let mut events = self.events.clone();
        events.sort_by(|a, b| a.t.total_cmp(&b.t));
        Session { header: None, events }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_a_session_with_its_header_and_round_trips() {
        let text = r#"{"session":1,"exhibit":"content/bunny","seed":7}
{"t":0.000,"ev":"down","id":1,"x":0.50,"y":0.50}
{"t":0.016,"ev":"move","id":1,"x":0.51,"y":0.50,"pressure":0.3}
{"t":0.900,"ev":"up","id":1,"x":0.60,"y":0.50}
"#;
        let s = Session::parse(text).expect("valid");
        assert_eq!(s.events.len(), 3);
        assert_eq!(s.header.as_ref().and_then(|h| h.seed), Some(7));
        assert_eq!(Session::parse(&s.to_jsonl()).expect("round trip"), s);
    }

    #[test]
    fn malformed_lines_name_their_number() {
        let e = Session::parse("{\"t\":0,\"ev\":\"down\",\"id\":1,\"x\":0,\"y\":0}\n{\"t\":0.1,\"ev\":\"jump\",\"id\":1,\"x\":0,\"y\":0}")
            .expect_err("bad kind");
        assert_eq!(e.line, 2);
        let e = Session::parse("{\"t\":1,\"ev\":\"down\",\"id\":1,\"x\":0,\"y\":0}\n\n{\"t\":0.5,\"ev\":\"up\",\"id\":1,\"x\":0,\"y\":0}")
            .expect_err("time goes back");
        assert_eq!(e.line, 3);
        assert!(Session::parse("not json").expect_err("junk").msg.contains("not a JSON object"));
    }

    #[test]
    fn times_beyond_a_day_are_refused() {
        let line = |t: &str| {
            format!(
                "{{\"t\":0,\"ev\":\"down\",\"id\":1,\"x\":0,\"y\":0}}\n{{\"t\":{t},\"ev\":\"up\",\"id\":1,\"x\":0,\"y\":0}}"
            )
        };
        assert!(Session::parse(&line("86400")).is_ok(), "a whole day is a session");
        for t in ["86400.5", "1e7", "1e308"] {
            let e = Session::parse(&line(t)).expect_err("too long");
            assert_eq!(e.line, 2, "{t}");
            assert!(e.msg.contains("longest session"), "{t}: {}", e.msg);
        }
    }
}
