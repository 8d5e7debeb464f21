//! Bulk transfers straight through the kernel's usbfs (`/dev/bus/usb/BBB/DDD`), for the
//! real-time thread.
//!
//! libusb's synchronous transfers allocate a transfer and its URBs on every call and take
//! its internal locks while they wait; here one URB and its result live in the link, a
//! transfer is `SUBMITURB`, `poll` for its completion, `REAPURBNDELAY`, and nothing else.
//! libusb still finds the devices; only their opened node is driven from here.

use std::fs::File;
use std::os::fd::AsRawFd;
use std::path::Path;
use std::time::{Duration, Instant};

use hapticd_core::transport::TransportError;
use nix::sys::ioctl::ioctl_num_type;
use nix::{request_code_none, request_code_read, request_code_readwrite, request_code_write};

/// The URB as usbfs takes it (`struct usbdevfs_urb`, without isochronous frames).
#[repr(C)]
struct Urb {
    kind: u8,
    endpoint: u8,
    status: i32,
    flags: u32,
    buffer: *mut libc::c_void,
    buffer_length: i32,
    actual_length: i32,
    start_frame: i32,
    number_of_packets: i32,
    error_count: i32,
    signal: u32,
    user_context: *mut libc::c_void,
}

/// `struct usbdevfs_getdriver`.
#[repr(C)]
struct GetDriver {
    interface: u32,
    driver: [u8; 256],
}

/// `struct usbdevfs_ioctl`: an ioctl passed to the driver bound to an interface.
#[repr(C)]
struct InterfaceIoctl {
    interface: i32,
    code: i32,
    data: *mut libc::c_void,
}

const URB_TYPE_BULK: u8 = 3;

// The request numbers of <linux/usbdevice_fs.h>, built by nix for this architecture's
// ioctl layout (the direction bits differ between, say, x86 and PowerPC).
const GETDRIVER: ioctl_num_type = request_code_write!(b'U', 8, size_of::<GetDriver>());
const SUBMITURB: ioctl_num_type = request_code_read!(b'U', 10, size_of::<Urb>());
const DISCARDURB: ioctl_num_type = request_code_none!(b'U', 11);
const REAPURB: ioctl_num_type = request_code_write!(b'U', 12, size_of::<*mut Urb>());
const REAPURBNDELAY: ioctl_num_type = request_code_write!(b'U', 13, size_of::<*mut Urb>());
const CLAIMINTERFACE: ioctl_num_type = request_code_read!(b'U', 15, size_of::<u32>());
const RELEASEINTERFACE: ioctl_num_type = request_code_read!(b'U', 16, size_of::<u32>());
const IOCTL: ioctl_num_type = request_code_readwrite!(b'U', 18, size_of::<InterfaceIoctl>());
const CLEAR_HALT: ioctl_num_type = request_code_read!(b'U', 21, size_of::<u32>());
const DISCONNECT: ioctl_num_type = request_code_none!(b'U', 22);

/// The last OS error as a transport error.
fn os_error() -> TransportError {
    errno_error(std::io::Error::last_os_error().raw_os_error().unwrap_or(0))
}

/// What an errno (from a call, or a URB's status) means to the loop.
fn errno_error(errno: i32) -> TransportError {
    match errno {
        libc::ENODEV | libc::ESHUTDOWN => TransportError::Disconnected,
        libc::ETIMEDOUT => TransportError::Timeout,
        code => TransportError::Io(code),
    }
}

/// Open the usbfs `node` for transfers, claiming nothing yet.
pub fn open_node(node: &Path) -> std::io::Result<File> {
    std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(node)
}

/// Claim `interface` of the usbfs `node`: EBUSY while another open file holds it.
pub fn claim_interface(node: &File, interface: u32) -> std::io::Result<()> {
    let mut claimed = interface;
    // SAFETY: CLAIMINTERFACE reads one unsigned int.
    if unsafe { libc::ioctl(node.as_raw_fd(), CLAIMINTERFACE as _, &mut claimed) } != 0 {
        return Err(std::io::Error::last_os_error());
    }
    Ok(())
}

/// One claimed interface of a device node, moving bulk transfers one at a time.
pub struct UsbfsDevice {
    node: File,
    interface: u32,
    urb: Urb,
    timeout: Duration,
}

// SAFETY: the URB's raw pointers only ever point into a caller's buffer for the duration of
// one transfer call; between calls they are dangling-but-unused, so moving the device to
// another thread is sound.
unsafe impl Send for UsbfsDevice {}

impl UsbfsDevice {
    /// Open `node`, take `interface` from any kernel driver bound to it, and claim it.
    /// Transfers give up after `timeout`.
    pub fn open(node: &Path, interface: u32, timeout: Duration) -> std::io::Result<Self> {
        let node = open_node(node)?;
        let fd = node.as_raw_fd();
        let mut bound = GetDriver {
            interface,
            driver: [0; 256],
        };
        // SAFETY: GETDRIVER fills one getdriver struct that lives across the call.
        let has_driver = unsafe { libc::ioctl(fd, GETDRIVER as _, &mut bound) } == 0;
        // "usbfs" is another program holding the interface: left to it (the claim fails).
        if has_driver && !bound.driver.starts_with(b"usbfs\0") {
            let mut request = InterfaceIoctl {
                interface: interface as i32,
                code: DISCONNECT as i32,
                data: std::ptr::null_mut(),
            };
            // SAFETY: IOCTL reads one request struct; DISCONNECT takes no data.
            if unsafe { libc::ioctl(fd, IOCTL as _, &mut request) } != 0 {
                return Err(std::io::Error::last_os_error());
            }
        }
        Self::claim(node, interface, timeout)
    }

    /// Claim `interface` of a device `node` already opened (with [`open_node`]). Transfers
    /// give up after `timeout`.
    pub fn claim(node: File, interface: u32, timeout: Duration) -> std::io::Result<Self> {
        claim_interface(&node, interface)?;
        Ok(Self::claimed(node, interface, timeout))
    }

    /// The device `node` whose `interface` is claimed (with [`claim_interface`]), as the
    /// guardian takes it once the daemon that held it is gone.
    pub fn claimed(node: File, interface: u32, timeout: Duration) -> Self {
        Self {
            node,
            interface,
            urb: Urb {
                kind: URB_TYPE_BULK,
                endpoint: 0,
                status: 0,
                flags: 0,
                buffer: std::ptr::null_mut(),
                buffer_length: 0,
                actual_length: 0,
                start_frame: 0,
                number_of_packets: 0,
                error_count: 0,
                signal: 0,
                user_context: std::ptr::null_mut(),
            },
            timeout,
        }
    }

    /// [rt] Send `bytes` to the OUT `endpoint`; all of them must go.
    pub fn write(&mut self, endpoint: u8, bytes: &[u8]) -> Result<(), TransportError> {
        // usbfs only reads an OUT buffer.
        let n = self.transfer(endpoint, bytes.as_ptr().cast_mut(), bytes.len())?;
        if n == bytes.len() {
            Ok(())
        } else {
            Err(TransportError::Io(libc::EIO))
        }
    }

    /// [rt] Receive one transfer from the IN `endpoint` into `bytes`; returns its length.
    pub fn read(&mut self, endpoint: u8, bytes: &mut [u8]) -> Result<usize, TransportError> {
        self.transfer(endpoint, bytes.as_mut_ptr(), bytes.len())
    }

    /// [main] Clear a halt (stall) of `endpoint`.
    pub fn clear_halt(&mut self, endpoint: u8) -> Result<(), TransportError> {
        let mut endpoint = u32::from(endpoint);
        // SAFETY: CLEAR_HALT reads one unsigned int.
        if unsafe { libc::ioctl(self.node.as_raw_fd(), CLEAR_HALT as _, &mut endpoint) } != 0 {
            return Err(os_error());
        }
        Ok(())
    }

    /// One URB on `endpoint` over `length` bytes at `buffer`, submitted and reaped before
    /// returning, so the kernel never touches the buffer after this call.
    fn transfer(
        &mut self,
        endpoint: u8,
        buffer: *mut u8,
        length: usize,
    ) -> Result<usize, TransportError> {
        let fd = self.node.as_raw_fd();
        let urb = &mut self.urb;
        urb.endpoint = endpoint;
        urb.status = 0;
        urb.buffer = buffer.cast();
        urb.buffer_length = length as i32;
        urb.actual_length = 0;
        // SAFETY: the URB and the buffer it points to outlive the transfer: it is reaped (or
        // discarded and reaped) below before either can move or be freed.
        if unsafe { libc::ioctl(fd, SUBMITURB as _, &mut *urb) } != 0 {
            return Err(os_error());
        }
        let reaped = self.reap();
        let urb = &self.urb;
        reaped?;
        if urb.status != 0 {
            return Err(errno_error(-urb.status));
        }
        Ok(urb.actual_length.max(0) as usize)
    }

    /// Wait for the URB in flight to complete, up to the timeout; past it, cancel it and
    /// take it back.
    fn reap(&mut self) -> Result<(), TransportError> {
        let fd = self.node.as_raw_fd();
        let deadline = Instant::now() + self.timeout;
        let mut done: *mut Urb = std::ptr::null_mut();
        loop {
            // SAFETY: REAPURBNDELAY writes one pointer to a valid location.
            if unsafe { libc::ioctl(fd, REAPURBNDELAY as _, &mut done) } == 0 {
                return Ok(());
            }
            let errno = std::io::Error::last_os_error().raw_os_error().unwrap_or(0);
            if errno != libc::EAGAIN {
                return Err(errno_error(errno));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            let mut ready = libc::pollfd {
                fd,
                events: libc::POLLOUT,
                revents: 0,
            };
            let wait_ms = left.as_nanos().div_ceil(1_000_000) as i32;
            // SAFETY: poll reads and writes one pollfd that lives across the call.
            unsafe { libc::poll(&mut ready, 1, wait_ms) };
        }
        // Too late: cancel, then collect the cancelled URB so the kernel lets go of it.
        // SAFETY: DISCARDURB takes the address of the URB in flight; REAPURB writes one
        // pointer.
        unsafe {
            libc::ioctl(fd, DISCARDURB as _, &mut self.urb);
            libc::ioctl(fd, REAPURB as _, &mut done);
        }
        Err(TransportError::Timeout)
    }
}

impl Drop for UsbfsDevice {
    fn drop(&mut self) {
        let mut interface = self.interface;
        // SAFETY: RELEASEINTERFACE reads one unsigned int. A device already gone fails, which
        // is fine: closing the node releases it anyway.
        unsafe { libc::ioctl(self.node.as_raw_fd(), RELEASEINTERFACE as _, &mut interface) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
    fn ioctl_numbers_are_the_kernel_abi() {
        // The values of <linux/usbdevice_fs.h> on 64-bit x86 and ARM.
        assert_eq!(size_of::<Urb>(), 56);
        assert_eq!(SUBMITURB, 0x8038_550a);
        assert_eq!(DISCARDURB, 0x550b);
        assert_eq!(REAPURB, 0x4008_550c);
        assert_eq!(REAPURBNDELAY, 0x4008_550d);
        assert_eq!(CLAIMINTERFACE, 0x8004_550f);
        assert_eq!(RELEASEINTERFACE, 0x8004_5510);
        assert_eq!(GETDRIVER, 0x4104_5508);
        assert_eq!(IOCTL, 0xc010_5512);
        assert_eq!(DISCONNECT, 0x5516);
        assert_eq!(CLEAR_HALT, 0x8004_5515);
    }

    #[test]
    fn a_node_that_is_not_usbfs_is_refused() {
        let file = std::env::temp_dir().join(format!("usbfs-{}", std::process::id()));
        std::fs::write(&file, b"").unwrap();
        let refused = UsbfsDevice::open(&file, 0, Duration::from_millis(10));
        std::fs::remove_file(&file).unwrap();
        assert_eq!(
            refused.err().and_then(|e| e.raw_os_error()),
            Some(libc::ENOTTY)
        );
    }
}
