//! The CPU priority of zenoh's threads.
//!
//! A remote client that floods the daemon with large messages costs CPU before any of
//! its requests reaches the scheduler: zenoh's receive threads read and reassemble every
//! message, even those the queryable then refuses as `busy`. On a machine with few
//! cores that CPU is taken from the serving loop, and so from every other client, local
//! or remote. cliffd therefore runs zenoh's threads at a lower priority than its own
//! (a higher Linux *nice* value, [`ZenohSettings::nice`](super::ZenohSettings::nice)):
//! while the serving loop has work, the scheduler gives it the CPU first, the receive
//! threads read less, and TCP's flow control slows the flooding sender down.
//!
//! Linux keeps a nice value per thread, and a new thread starts with the nice value of
//! the thread that created it. zenoh creates its runtimes' threads lazily, from the
//! thread that first uses the runtime, and later ones from its own threads. So the
//! session is opened on a short-lived thread whose nice value was raised first
//! ([`on_lowered_thread`]); every thread zenoh starts from then on inherits it, and the
//! daemon's own threads keep theirs. Raising a nice value needs no privilege; lowering
//! it again would, which is why the thread that was lowered ends afterwards.

use std::io;

/// The largest nice increment (Linux's nice values run from -20 to 19).
pub const MAX_NICE: i32 = 19;

/// Raise the calling thread's nice value by `increment` (0 leaves it), capped at 19.
pub fn lower_this_thread(increment: i32) -> io::Result<()> {
    if increment == 0 {
        return Ok(());
    }
    if !(0..=MAX_NICE).contains(&increment) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("nice increment {increment}: must be from 0 to {MAX_NICE}"),
        ));
    }
    // SAFETY: gettid has no preconditions.
    let tid = unsafe { libc::gettid() } as libc::id_t;
    // getpriority returns -1 for a nice value of -1 too: errno tells them apart.
    // SAFETY: errno is thread-local; getpriority only reads the scheduler's state.
    let now = unsafe {
        *libc::__errno_location() = 0;
        libc::getpriority(libc::PRIO_PROCESS, tid)
    };
    if now == -1 && io::Error::last_os_error().raw_os_error() != Some(0) {
        return Err(io::Error::last_os_error());
    }
    let target = (now + increment).min(MAX_NICE);
    // SAFETY: PRIO_PROCESS with a thread id changes that thread alone on Linux.
    if unsafe { libc::setpriority(libc::PRIO_PROCESS, tid, target) } != 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(())
}

/// Run `f` on a new thread whose nice value is `increment` above the caller's, and
/// return its result. Threads that `f` starts (directly or through a runtime it
/// initialises) inherit the lowered priority; the caller's own stays as it was.
pub fn on_lowered_thread<T: Send>(increment: i32, f: impl FnOnce() -> T + Send) -> io::Result<T> {
    std::thread::scope(|scope| {
        let thread = std::thread::Builder::new()
            .name("cliffd-zenoh-open".into())
            .spawn_scoped(scope, move || {
                lower_this_thread(increment)?;
                Ok(f())
            })?;
        thread
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    })
}

/// The nice value of thread `tid` of process `pid`, from `/proc` (for tests and logs).
pub fn nice_of(pid: u32, tid: u32) -> io::Result<i32> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/task/{tid}/stat"))?;
    // the name (field 2) is in parentheses and may hold spaces: count after its end
    let after = stat
        .rfind(')')
        .map(|i| &stat[i + 1..])
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidData, "no ')' in stat"))?;
    // fields from 3 on; nice is field 19
    after
        .split_whitespace()
        .nth(19 - 3)
        .and_then(|f| f.parse().ok())
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidData, "no nice field in stat"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn own_nice() -> i32 {
        let tid = unsafe { libc::gettid() } as u32;
        nice_of(std::process::id(), tid).unwrap()
    }

    #[test]
    fn a_lowered_thread_and_its_children_run_nicer_and_the_caller_does_not() {
        let before = own_nice();
        let (inside, child) = on_lowered_thread(5, || {
            let child = std::thread::spawn(own_nice).join().unwrap();
            (own_nice(), child)
        })
        .unwrap();
        assert_eq!(inside, (before + 5).min(MAX_NICE));
        assert_eq!(
            child, inside,
            "a thread started there inherits the nice value"
        );
        assert_eq!(own_nice(), before, "the caller keeps its priority");
    }

    #[test]
    fn zero_leaves_the_priority_and_out_of_range_is_refused() {
        let before = own_nice();
        assert_eq!(on_lowered_thread(0, own_nice).unwrap(), before);
        let e = on_lowered_thread(20, || ()).unwrap_err();
        assert!(e.to_string().contains("from 0 to 19"), "{e}");
        assert!(on_lowered_thread(-1, || ()).is_err());
    }
}
