//! Third-party decoders called behind one guard: a panic inside one on a hostile file (a
//! `todo!`, an index out of bounds, an assertion) becomes a one-line error naming the file,
//! and its message is kept out of the terminal. What a decoder would allocate is checked
//! against the memory budget before it is called; the guard is the last line.

use std::cell::Cell;
use std::panic::{AssertUnwindSafe, PanicHookInfo, catch_unwind};
use std::sync::Once;

thread_local! {
    /// Whether this thread is inside `decode`, and the message of the last panic there.
    static INSIDE: Cell<bool> = const { Cell::new(false) };
    static MESSAGE: Cell<Option<String>> = const { Cell::new(None) };
}

/// Installs, once, a panic hook that keeps the message of a panic inside `decode` for its
/// error and passes every other panic to the hook that was there before.
fn install_hook() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info: &PanicHookInfo<'_>| {
            if INSIDE.get() {
                MESSAGE.set(Some(message(info)));
            } else {
                previous(info);
            }
        }));
    });
}

/// A panic's payload as one line of at most 120 characters.
fn message(info: &PanicHookInfo<'_>) -> String {
    let payload = info.payload();
    let text = payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "no message".into());
    let line = text.split_whitespace().collect::<Vec<_>>().join(" ");
    if line.chars().count() > 120 { format!("{}...", line.chars().take(117).collect::<String>()) } else { line }
}

/// Runs the decoder call `f`; a panic inside it is returned as "`decoder` failed on this
/// input (its message)" instead of unwinding further or printing.
pub fn decode<T>(decoder: &str, f: impl FnOnce() -> T) -> Result<T, String> {
    install_hook();
    let outer = INSIDE.replace(true);
    let result = catch_unwind(AssertUnwindSafe(f));
    INSIDE.set(outer);
    result.map_err(|_| {
        let why = MESSAGE.take().unwrap_or_else(|| "no message".into());
        format!("{decoder} failed on this input ({why})")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_inside_becomes_an_error_with_its_message_and_outside_still_unwinds() {
        assert_eq!(decode("test", || 7), Ok(7));
        let e = decode("vdb-rs", || -> u32 { panic!("Not supported\n AffineMap") }).unwrap_err();
        assert_eq!(e, "vdb-rs failed on this input (Not supported AffineMap)");
        let nested = decode("outer", || decode("inner", || -> u32 { todo!("version 200") }));
        assert_eq!(nested, Ok(Err("inner failed on this input (not yet implemented: version 200)".into())));
        assert!(!INSIDE.get());
        assert!(std::panic::catch_unwind(|| -> u32 { panic!("outside") }).is_err());
    }
}
