//! Third-party decoders (Basis Universal here, Draco in the cook crate) run on untrusted bytes.
//! Their panics are caught and reported as the file's error: one damaged texture or mesh is a
//! clear message naming the file, not a crash of the whole cook.

use std::cell::Cell;

thread_local! {
    /// Set while this thread runs a guarded decoder, whose panics are caught and reported.
    static CATCHING: Cell<bool> = const { Cell::new(false) };
}

/// Puts a panic hook in front of the one in place that says nothing for a panic on a thread
/// inside [`catch_decoder_panic`] (once per process: a side effect a library rarely has, taken
/// because the panic is reported as our error). Under `panic = "abort"` nothing is caught;
/// this workspace unwinds.
fn quiet_while_catching() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !CATCHING.with(Cell::get) {
                previous(info)
            }
        }));
    });
}

/// Runs `f`, a decoder over untrusted bytes; a panic in it comes back as `Err` with the panic's
/// message. Only values `f` owns or returns may be trusted afterwards: state it borrowed
/// mutably may be half-updated (callers pass it bytes and take what it returns).
pub fn catch_decoder_panic<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    quiet_while_catching();
    let outer = CATCHING.with(|c| c.replace(true));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    CATCHING.with(|c| c.set(outer));
    result.map_err(|panic| {
        panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "no message".to_string())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_is_its_message_and_the_flag_is_restored() {
        assert_eq!(catch_decoder_panic(|| 7), Ok(7));
        let e = catch_decoder_panic(|| -> u8 { panic!("bad block {}", 3) }).unwrap_err();
        assert_eq!(e, "bad block 3");
        let nested = catch_decoder_panic(|| {
            let inner = catch_decoder_panic(|| -> u8 { panic!("inner") });
            assert!(CATCHING.with(Cell::get), "still inside the outer guard");
            inner
        });
        assert_eq!(nested, Ok(Err("inner".to_string())));
        assert!(!CATCHING.with(Cell::get));
    }
}
