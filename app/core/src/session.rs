//! The touch-session format (DESIGN §11): JSON Lines, an optional header object with
//! `"session"` (format version 1), then one touch event per line. Unknown keys are ignored;
//! a malformed line is an error naming its line number. The kiosk records visitors in the same
//! format, so a museum's real session replays in a test.

use crate::gesture::{TouchEvent, TouchKind};
use serde::{Deserialize, Serialize};

/// The session format version this build reads and writes.
pub const SESSION_VERSION: u32 = 1;

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_design_example_and_round_trips() {
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
}
