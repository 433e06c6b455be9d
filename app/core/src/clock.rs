//! The fixed-clock loop every driver of IsoKiosk steps the core by: the kiosk's windows, `kiosk
//! replay` and the core's own session runner ([`crate::kiosk::run_session`]) all step through one
//! [`Stepper`]. It takes step k at time k / fps (computed, never accumulated, so step k's time is
//! the same in a minute-long test and a month-long run) and, before each step, hands the core
//! every touch of its [`TouchSource`] due at it (a recorded touch at the first step at or after its
//! time). One loop, so that a session gives the same trace, byte for byte, from all three; the
//! drivers differ only in what they do with a step's frame.

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

    /// The time of the last step of a run covering `secs` seconds from time 0.
    pub fn end_of(&self, secs: f64) -> f64 {
        self.time(self.steps_for(secs) - 1)
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

/// What the loop hands touches to: the explorer and the kiosk.
pub trait Touchable {
    /// Takes one touch (its time is at or before the coming step's).
    fn touch(&mut self, e: &TouchEvent);
}

/// Where a loop's touches come from: a recorded session ([`Playing`]), or the kiosk's live windows
/// with or without one.
pub trait TouchSource {
    /// Hands `to` every touch due at step time `t`, in order, once.
    fn due(&mut self, t: f64, to: &mut dyn FnMut(&TouchEvent));
}

/// The fixed-clock loop: a [`FixedClock`] and the [`TouchSource`] its steps take touches from.
/// Each driver writes `while let Some(t) = stepper.next(now, &mut core) { core.step(t) … }`.
#[derive(Debug)]
pub struct Stepper<S> {
    clock: FixedClock,
    source: S,
}

impl<S: TouchSource> Stepper<S> {
    /// A loop stepping `fps` times a second with touches from `source`, before its first step.
    pub fn new(fps: f64, source: S) -> Self {
        Self { clock: FixedClock::new(fps), source }
    }

    /// The loop's clock.
    pub fn clock(&self) -> &FixedClock {
        &self.clock
    }

    /// The touch source (the live windows queue their touches in it).
    pub fn source(&mut self) -> &mut S {
        &mut self.source
    }

    /// Takes the next step if it is due by `now`: hands `core` the touches due at it, then returns
    /// its time for the caller to step `core` to.
    pub fn next(&mut self, now: f64, core: &mut impl Touchable) -> Option<f64> {
        let t = self.clock.next_due(now)?;
        self.source.due(t, &mut |e| core.touch(e));
        Some(t)
    }
}

/// A recorded session being played by a [`SessionFeed`]: the touch source of replays.
#[derive(Debug)]
pub struct Playing<'s> {
    session: &'s Session,
    feed: SessionFeed,
}

impl<'s> Playing<'s> {
    /// Plays `session` from time 0 with `feed`.
    pub fn new(session: &'s Session, feed: SessionFeed) -> Self {
        Self { session, feed }
    }
}

impl TouchSource for Playing<'_> {
    fn due(&mut self, t: f64, to: &mut dyn FnMut(&TouchEvent)) {
        self.feed.due(self.session, t, to);
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
        /// Records each touch with the time of the step it came before.
        struct Got(Vec<(f64, f64)>, f64);
        impl Touchable for Got {
            fn touch(&mut self, e: &TouchEvent) {
                self.0.push((self.1, e.t));
            }
        }
        let run = |feed: SessionFeed, secs: f64| {
            let mut stepper = Stepper::new(60.0, Playing::new(&session, feed));
            let mut got = Got(Vec::new(), 0.0);
            let mut steps = 0;
            // The step's time is known only after its touches: each is checked against the
            // clock's time for the step being taken.
            while let Some(t) = {
                got.1 = stepper.clock().time(stepper.clock().steps());
                stepper.next(secs, &mut got)
            } {
                assert_eq!(t, got.1);
                steps += 1;
            }
            assert_eq!(steps, stepper.clock().steps_for(secs), "every step up to {secs} s is taken");
            got.0
        };
        // The touch at 0.05 s comes at step 3 (0.05 s) within the slack, not at step 4.
        assert_eq!(run(SessionFeed::once(), 10.0), vec![(0.0, 0.0), (3.0 / 60.0, 0.05)]);
        // Repeating with a 1 s gap: again at 1.05 s (the first step at or after the gap), and so on.
        let again = run(SessionFeed::repeating(1.0), 3.0);
        assert_eq!(again.len(), 6, "{again:?}");
        assert!(again[2].1 >= 1.05 && again[2].1 < 1.05 + 1.0 / 60.0, "{again:?}");
    }
}
