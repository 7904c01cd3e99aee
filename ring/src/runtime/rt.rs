//! Realtime hardening of a member's cycle thread (`realtime` clock): SCHED_FIFO and locked
//! memory when the process may have them (root, CAP_SYS_NICE / CAP_IPC_LOCK, or an rtprio and
//! memlock limit), and a plain statement of what it got. Two single libc calls on plain values.
#![allow(unsafe_code)]

/// SCHED_FIFO priority of the cycle thread: above ordinary threads, below the kernel's own
/// (threaded interrupts run at 50).
pub const FIFO_PRIORITY: i32 = 40;

/// Ask for SCHED_FIFO on the calling thread and lock the process's memory (pages as they are
/// touched: MCL_ONFAULT, so reserved but unused address space costs nothing). Returns what was
/// granted, e.g. `SCHED_FIFO 40, memory locked` or the reasons it was not.
pub fn harden_cycle_thread() -> String {
    let param = libc::sched_param {
        sched_priority: FIFO_PRIORITY,
    };
    // SAFETY: sched_setscheduler(2) on the calling thread (pid 0) reads one plain struct that
    // lives on this stack for the duration of the call.
    let sched = if unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) } == 0 {
        format!("SCHED_FIFO {FIFO_PRIORITY}")
    } else {
        format!(
            "normal scheduling (SCHED_FIFO refused: {}; needs root, CAP_SYS_NICE or an rtprio limit)",
            std::io::Error::last_os_error()
        )
    };
    // SAFETY: mlockall(2) takes flags only and touches no memory of ours.
    let lock = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE | libc::MCL_ONFAULT) };
    let mem = if lock == 0 {
        "memory locked".to_string()
    } else {
        format!(
            "memory not locked ({}; needs CAP_IPC_LOCK or a memlock limit)",
            std::io::Error::last_os_error()
        )
    };
    format!("{sched}, {mem}")
}

/// The calling thread's scheduling as it is (a member started under `chrt` inherits it).
pub fn current_scheduling() -> String {
    // SAFETY: sched_getscheduler(2) on the calling thread takes and returns plain integers.
    let policy = unsafe { libc::sched_getscheduler(0) };
    let mut param = libc::sched_param { sched_priority: 0 };
    // SAFETY: sched_getparam(2) writes one plain struct that lives on this stack.
    let _ = unsafe { libc::sched_getparam(0, &mut param) };
    match policy {
        libc::SCHED_FIFO => format!("SCHED_FIFO {} (inherited)", param.sched_priority),
        libc::SCHED_RR => format!("SCHED_RR {} (inherited)", param.sched_priority),
        _ => {
            // SAFETY: getpriority(2) takes plain integers; -1 can be a valid nice value, so
            // errno is not consulted (the call cannot fail for the calling thread).
            let nice = unsafe { libc::getpriority(libc::PRIO_PROCESS, 0) };
            format!("normal scheduling (nice {nice})")
        }
    }
}
