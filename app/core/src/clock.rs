//! The fixed clock every loop of IsoKiosk steps the core by: the kiosk's windows, `kiosk replay`
//! and the core's own session runner ([`crate::kiosk::run_session`]) all take step k at time
//! k / fps (computed, never accumulated, so step k's time is the same in a minute-long test and a
//! month-long run) and hand the core each recorded touch at the first step at or after its time.
//! One clock and one feed, so that a session gives the same trace, byte for byte, from all three.

use crate::gesture::TouchEvent;
use crate::session::Session;

/// A touch is due at a step when its time is within this of the step's (recorded times are
/// printed decimals; a step's time is a binary fraction).
const DUE_SLACK: f64 = 1e-9;

/// Steps at k / fps.
#[derive(Clone, Copy, Debug)]
pub struct FixedClock {
    fps: f64,
    dt: f64,
    steps: u64,
}

impl FixedClock {
    /// A clock stepping `fps` times a second, before its first step.
    pub fn new(fps: f64) -> Self {
        Self { fps, dt: 1.0 / fps, steps: 0 }
    }

    /// Seconds between steps.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Steps taken so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The time of step `k`.
    pub fn time(&self, k: u64) -> f64 {
        k as f64 * self.dt
    }

    /// The steps needed to cover `secs` seconds, both ends included.
    pub fn steps_for(&self, secs: f64) -> u64 {
        (secs * self.fps).ceil() as u64 + 1
    }

    /// Takes the next step if it is due by `now` (its time ≤ `now`): returns its time.
    pub fn next_due(&mut self, now: f64) -> Option<f64> {
        let t = self.time(self.steps);
        (t <= now).then(|| {
            self.steps += 1;
            t
        })
    }
}

/// Where the playing of a recorded session stands: its touches are handed out at their step,
/// once, or over and over (a soak run: each new visitor `gap` seconds after the last one's final
/// touch). The session itself is the caller's (a long one is not copied).
#[derive(Clone, Copy, Debug, Default)]
pub struct SessionFeed {
    next: usize,
    offset: f64,
    repeat: Option<f64>,
}

impl SessionFeed {
    /// Plays a session from time 0, once.
    pub fn once() -> Self {
        Self::default()
    }

    /// Plays a session from time 0, again `gap` seconds after each playing's end.
    pub fn repeating(gap: f64) -> Self {
        Self { repeat: Some(gap), ..Self::default() }
    }

    /// Hands `feed` every touch of `session` due at step time `t`, in order.
    pub fn due(&mut self, session: &Session, t: f64, feed: &mut dyn FnMut(&TouchEvent)) {
        let events = &session.events;
        loop {
            if self.next >= events.len() {
                match self.repeat {
                    Some(gap) if t >= self.offset + session.duration() + gap => {
                        self.offset = t;
                        self.next = 0;
                        continue;
                    }
                    _ => break,
                }
            }
            let e = events[self.next];
            if e.t + self.offset > t + DUE_SLACK {
                break;
            }
            feed(&TouchEvent { t: e.t + self.offset, ..e });
            self.next += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_times_are_computed_not_accumulated() {
        let mut c = FixedClock::new(60.0);
        let mut sum = 0.0;
        for _ in 0..1_000_000 {
            sum += c.dt();
        }
        // An accumulated clock drifts; step k's time is exactly k × dt.
        assert_ne!(sum, c.time(1_000_000));
        assert_eq!(c.time(1_000_000), 1_000_000.0 * (1.0 / 60.0));
        assert_eq!(c.next_due(-1.0), None, "step 0 is at t = 0");
        assert_eq!(c.next_due(0.0), Some(0.0));
        assert_eq!(c.next_due(0.01), None, "step 1 is at 1/60 s");
        assert_eq!(c.next_due(1.0 / 60.0), Some(1.0 / 60.0));
        assert_eq!(c.steps(), 2);
        assert_eq!(c.steps_for(1.0), 61);
    }

    #[test]
    fn a_session_is_fed_at_its_steps_once_or_over_and_over() {
        let text = "{\"t\": 0.0, \"ev\": \"down\", \"id\": 1, \"x\": 0.5, \"y\": 0.5}\n\
                    {\"t\": 0.05, \"ev\": \"up\", \"id\": 1, \"x\": 0.5, \"y\": 0.5}\n";
        let session = Session::parse(text).expect("session");
        let run = |mut feed: SessionFeed, secs: f64| {
            let mut clock = FixedClock::new(60.0);
            let mut got = Vec::new();
            while let Some(t) = clock.next_due(secs) {
                feed.due(&session, t, &mut |e| got.push((t, e.t)));
            }
            got
        };
        // The touch at 0.05 s comes at step 3 (0.05 s) within the slack, not at step 4.
        assert_eq!(run(SessionFeed::once(), 10.0), vec![(0.0, 0.0), (3.0 / 60.0, 0.05)]);
        // Repeating with a 1 s gap: again at 1.05 s (the first step at or after the gap), and so on.
        let again = run(SessionFeed::repeating(1.0), 3.0);
        assert_eq!(again.len(), 6, "{again:?}");
        assert!(again[2].1 >= 1.05 && again[2].1 < 1.05 + 1.0 / 60.0, "{again:?}");
    }
}
