//! The terminal, for `top`: keys as they are pressed.

/// The terminal in a mode where a key reaches hapticctl as it is pressed (not at Enter),
/// restored when dropped; None when standard input is no terminal.
pub struct KeyReader {
    saved: libc::termios,
}

impl KeyReader {
    /// Keys from standard input as they are pressed; None when it is no terminal.
    pub fn new() -> Option<Self> {
        // SAFETY: termios is plain data; tcgetattr fills it or fails.
        let mut saved: libc::termios = unsafe { std::mem::zeroed() };
        // SAFETY: a valid descriptor and a termios to fill.
        if unsafe { libc::tcgetattr(libc::STDIN_FILENO, &mut saved) } != 0 {
            return None;
        }
        let mut keys = saved;
        keys.c_lflag &= !(libc::ICANON | libc::ECHO);
        // SAFETY: a valid descriptor and settings derived from its own.
        if unsafe { libc::tcsetattr(libc::STDIN_FILENO, libc::TCSANOW, &keys) } != 0 {
            return None;
        }
        Some(Self { saved })
    }

    /// Wait up to `timeout` for a key; the key, if one was pressed.
    pub fn key(&self, timeout: std::time::Duration) -> Option<u8> {
        let mut poll = libc::pollfd {
            fd: libc::STDIN_FILENO,
            events: libc::POLLIN,
            revents: 0,
        };
        let ms = timeout.as_millis().min(i32::MAX as u128) as i32;
        // SAFETY: one pollfd, and its count.
        if unsafe { libc::poll(&mut poll, 1, ms) } <= 0 {
            return None;
        }
        let mut key = 0u8;
        // SAFETY: one byte read into one byte.
        let n = unsafe { libc::read(libc::STDIN_FILENO, (&raw mut key).cast(), 1) };
        (n == 1).then_some(key)
    }
}

impl Drop for KeyReader {
    fn drop(&mut self) {
        // SAFETY: restoring the settings read at the start.
        unsafe { libc::tcsetattr(libc::STDIN_FILENO, libc::TCSANOW, &self.saved) };
    }
}
