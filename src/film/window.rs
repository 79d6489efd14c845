//! A window of the frame: the pixels a render (or a piece of one) covers, as pbrt-v4's
//! crop window in whole pixels. Pixel coordinates stay those of the whole frame, so a
//! pixel's samples do not depend on which window it is rendered in.

use serde::{Deserialize, Serialize};
use std::fmt;

/// Pixels `x0..x1` by `y0..y1` of a frame (half-open, `x0 < x1`, `y0 < y1`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Window {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// Column after the last.
    pub x1: u32,
    /// Row after the last.
    pub y1: u32,
}

impl Window {
    /// The whole of a `width` x `height` frame.
    pub fn full(width: u32, height: u32) -> Self {
        Self { x0: 0, y0: 0, x1: width, y1: height }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }

    /// Pixels covered.
    pub fn area(&self) -> u64 {
        self.width() as u64 * self.height() as u64
    }

    /// Whether `other` lies inside this window.
    pub fn contains(&self, other: &Window) -> bool {
        self.x0 <= other.x0 && other.x1 <= self.x1 && self.y0 <= other.y0 && other.y1 <= self.y1
    }

    /// Parses `X0,Y0,X1,Y1` and checks that it is a non-empty window of a `width` x `height` frame.
    pub fn parse(text: &str, width: u32, height: u32) -> Result<Self, String> {
        let bad = |why: &str| format!("--region {text}: {why}");
        let n: Vec<u32> = text
            .split(',')
            .map(|v| v.trim().parse())
            .collect::<Result<_, _>>()
            .map_err(|_| bad("expected X0,Y0,X1,Y1, four pixel coordinates"))?;
        let [x0, y0, x1, y1] = n[..] else {
            return Err(bad("expected X0,Y0,X1,Y1, four pixel coordinates"));
        };
        let w = Self { x0, y0, x1, y1 };
        w.check(width, height).map_err(|e| bad(&e))?;
        Ok(w)
    }

    /// Checks that the window is non-empty and inside a `width` x `height` frame.
    pub fn check(&self, width: u32, height: u32) -> Result<(), String> {
        if self.x0 >= self.x1 || self.y0 >= self.y1 {
            return Err("the window is empty (it needs X0 < X1 and Y0 < Y1)".into());
        }
        if !Self::full(width, height).contains(self) {
            return Err(format!("the window reaches outside the {width}x{height} frame"));
        }
        Ok(())
    }
}

impl fmt::Display for Window {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{},{},{},{}", self.x0, self.y0, self.x1, self.y1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_windows_inside_the_frame_only() {
        assert_eq!(Window::parse("1, 2,30,40", 64, 48), Ok(Window { x0: 1, y0: 2, x1: 30, y1: 40 }));
        for bad in ["1,2,3", "1,2,3,4,5", "a,0,1,1", "5,0,5,8", "0,6,8,3", "0,0,65,8", "-1,0,2,2"] {
            let err = Window::parse(bad, 64, 48).unwrap_err();
            assert!(err.starts_with(&format!("--region {bad}: ")), "{err}");
        }
        assert_eq!(Window::full(64, 48).to_string(), "0,0,64,48");
    }
}
