//! The byte link to the chip: anything that sends bytes and receives them with a deadline.

use std::io::{self, Read, Write};
use std::os::unix::net::UnixStream;
use std::time::Duration;

/// A link to the chip.
pub trait Link: Send {
    /// Sends every byte.
    fn send(&mut self, bytes: &[u8]) -> io::Result<()>;
    /// Waits up to `wait` for bytes and reads what came; `Ok(0)`: nothing came in time. A link
    /// the other side closed is an error ([`io::ErrorKind::UnexpectedEof`]).
    fn receive(&mut self, buf: &mut [u8], wait: Duration) -> io::Result<usize>;
}

/// Zero timeouts mean "block forever" to the operating system: never ask for one.
fn at_least_1ms(wait: Duration) -> Duration {
    wait.max(Duration::from_millis(1))
}

fn closed() -> io::Error {
    io::Error::new(io::ErrorKind::UnexpectedEof, "the link was closed")
}

/// QEMU's UART on a Unix socket (or one end of a socket pair in tests).
impl Link for UnixStream {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.write_all(bytes)
    }

    fn receive(&mut self, buf: &mut [u8], wait: Duration) -> io::Result<usize> {
        self.set_read_timeout(Some(at_least_1ms(wait)))?;
        received(self.read(buf))
    }
}

/// One read's outcome as `Link::receive` reports it: bytes, 0 when nothing came in time (or a
/// signal interrupted the wait), and end of stream as the link closing.
fn received(read: io::Result<usize>) -> io::Result<usize> {
    match read {
        Ok(0) => Err(closed()),
        Ok(n) => Ok(n),
        Err(e)
            if matches!(
                e.kind(),
                io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted
            ) =>
        {
            Ok(0)
        }
        Err(e) => Err(e),
    }
}

/// A board's serial port (or a pty), opened with the `serialport` crate.
pub struct SerialLink {
    port: Box<dyn serialport::SerialPort>,
}

impl std::fmt::Debug for SerialLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("SerialLink")
            .field(&self.port.name())
            .finish()
    }
}

impl Link for SerialLink {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.port.write_all(bytes)?;
        self.port.flush()
    }

    fn receive(&mut self, buf: &mut [u8], wait: Duration) -> io::Result<usize> {
        self.port.set_timeout(at_least_1ms(wait))?;
        received(self.port.read(buf))
    }
}

/// Opens a serial port at `baud` (8N1, no flow control), exclusively: `serialport` takes the
/// port with TIOCEXCL and an exclusive `flock`, so a port another program holds that way (a
/// second firmware-sim, most terminal programs) is refused as busy.
pub fn open_serial(path: &str, baud: u32) -> Result<SerialLink, String> {
    if !std::path::Path::new(path).exists() {
        return Err(format!(
            "serial port {path}: no such device (is the board plugged in?)"
        ));
    }
    let port = serialport::new(path, baud)
        .timeout(Duration::from_millis(100))
        .open()
        .map_err(|e| match e.kind {
            // What serialport reports for EBUSY from TIOCEXCL and for a held flock.
            serialport::ErrorKind::NoDevice => {
                format!("serial port {path} is busy: another program has it open")
            }
            _ => format!("cannot open serial port {path}: {}", e.description),
        })?;
    Ok(SerialLink { port })
}
