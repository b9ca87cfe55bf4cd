//! Per-frame resources that a pass reads from the previous frame while writing this frame's
//! (temporal reprojection, cache history).

/// Two values of which one is this frame's ([`PingPong::current`]) and the other the previous
/// frame's ([`PingPong::previous`]); [`PingPong::swap`] at each frame's end makes this frame's the
/// previous one. Swapping exchanges the roles, not the values: no resource is copied or remade.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PingPong<T> {
    values: [T; 2],
    current: usize,
}

impl<T> PingPong<T> {
    /// `current` is this frame's value, `previous` the last frame's.
    pub fn new(current: T, previous: T) -> Self {
        Self {
            values: [current, previous],
            current: 0,
        }
    }

    /// This frame's value.
    pub fn current(&self) -> &T {
        &self.values[self.current]
    }

    /// This frame's value, to write.
    pub fn current_mut(&mut self) -> &mut T {
        &mut self.values[self.current]
    }

    /// The previous frame's value.
    pub fn previous(&self) -> &T {
        &self.values[1 - self.current]
    }

    /// Both, as `(current, previous)`: a pass writes the one while reading the other.
    pub fn pair(&self) -> (&T, &T) {
        (self.current(), self.previous())
    }

    /// Ends the frame: this frame's value becomes the previous one, and the previous one is
    /// reused as the next frame's.
    pub fn swap(&mut self) {
        self.current = 1 - self.current;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn swapping_exchanges_current_and_previous() {
        let mut p = PingPong::new("a", "b");
        assert_eq!(p.pair(), (&"a", &"b"));
        p.swap();
        assert_eq!((p.current(), p.previous()), (&"b", &"a"));
        *p.current_mut() = "c";
        p.swap();
        assert_eq!(p.pair(), (&"a", &"c"));
        p.swap();
        p.swap();
        assert_eq!(p.pair(), (&"a", &"c"), "two swaps are none");
    }
}
