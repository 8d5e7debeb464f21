//! What the renderer will take on: the size of one frame, how many streams a connection, a
//! user and everyone together may hold open, the pixels a second they may ask for, and the
//! memory their rings may hold. Set on the command line (`--max-…`, declared with the rest
//! of it in `hapticd_service::cli`, so that its manual page has them); the defaults fit a
//! 2-core machine drawing on lavapipe, where hapticd's haptic thread takes one core and the
//! drawing thread shares the other.
//!
//! A frame is charged at least [`FRAME_FLOOR`] pixels: a 1 × 1 frame is not free (reading
//! the world, recording, submitting and waiting, the status line, the signal), and without a
//! floor many tiny streams would fill the drawing thread within any pixel budget.

use hapticd_ipc::frame_ring::SLOTS;
pub use hapticd_service::cli::RenderLimits as Limits;

use crate::error::Error;
use crate::options::Request;

/// Pixels a frame is charged at least: what its fixed cost is worth on lavapipe. Its frame
/// times (0.9 ms at 640 × 360, 2.9 ms at 1280 × 720, `RENDERING.md`) fit 0.23 ms a frame
/// and 2.9 ns a pixel, and 0.23 ms draw about 320 × 240 pixels.
pub const FRAME_FLOOR: u64 = 320 * 240;

/// Pixels of a frame of `size`.
fn pixels((width, height): (u32, u32)) -> u64 {
    u64::from(width) * u64::from(height)
}

/// Pixels a second a stream of `request` is charged.
pub fn pixel_rate(request: &Request) -> u64 {
    (pixels(request.size).max(FRAME_FLOOR) as f64 * request.rate).ceil() as u64
}

/// Bytes a ring for frames of `size` holds.
pub fn ring_bytes(size: (u32, u32)) -> u64 {
    SLOTS as u64 * pixels(size) * 4
}

/// One open stream, as the limits see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Held<'a> {
    /// The viewer's unique bus name.
    pub owner: &'a str,
    /// The viewer's Unix user.
    pub uid: u32,
    /// What it asked for.
    pub request: &'a Request,
}

/// A stream asked for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Asked<'a> {
    /// The caller's unique bus name.
    pub owner: &'a str,
    /// The caller's Unix user.
    pub uid: u32,
    /// What it asks for.
    pub request: &'a Request,
    /// Whether an identical stream is drawn already (it would share that drawing).
    pub shared: bool,
}

/// What the limits let in. A trait, as the limits are declared with the rest of the
/// command line in `hapticd_service::cli`.
pub trait Admission {
    /// Whether one frame of `request` may be drawn.
    fn check_frame(&self, request: &Request) -> Result<(), Error>;

    /// Whether stream `asked` may open beside the streams `held` (the distinct drawings'
    /// requests among them in `drawn`), or which limit it would pass.
    fn check_stream(&self, asked: &Asked, held: &[Held], drawn: &[&Request]) -> Result<(), Error>;
}

impl Admission for Limits {
    fn check_frame(&self, request: &Request) -> Result<(), Error> {
        let (width, height) = request.size;
        let asked = pixels(request.size);
        if asked > self.max_frame_pixels {
            return Err(Error::FrameTooLarge(format!(
                "{width} × {height} is {asked} pixels, over the most one frame may have \
                 (max-frame-pixels = {})",
                self.max_frame_pixels
            )));
        }
        Ok(())
    }

    fn check_stream(&self, asked: &Asked, held: &[Held], drawn: &[&Request]) -> Result<(), Error> {
        self.check_frame(asked.request)?;
        let (owner, uid) = (asked.owner, asked.uid);
        let by_caller = held.iter().filter(|h| h.owner == owner).count();
        let by_user: Vec<_> = held.iter().filter(|h| h.uid == uid).collect();
        let too_many = |whose: String, open: usize, limit: &str, value: u32| {
            Err(Error::TooManyStreams(format!(
                "{whose} {open} streams open, the most allowed ({limit} = {value}); close one \
                 first"
            )))
        };
        if by_caller >= self.max_streams_per_caller as usize {
            let whose = format!("this connection ({owner}) has");
            return too_many(
                whose,
                by_caller,
                "max-streams-per-caller",
                self.max_streams_per_caller,
            );
        }
        if by_user.len() >= self.max_streams_per_user as usize {
            let whose = format!("user {uid} has");
            return too_many(
                whose,
                by_user.len(),
                "max-streams-per-user",
                self.max_streams_per_user,
            );
        }
        if held.len() >= self.max_streams as usize {
            return too_many(
                "the renderer has".into(),
                held.len(),
                "max-streams",
                self.max_streams,
            );
        }
        let rate = pixel_rate(asked.request);
        let user_rate: u64 = by_user.iter().map(|h| pixel_rate(h.request)).sum();
        if user_rate + rate > self.max_pixel_rate_per_user {
            return Err(Error::PixelRateTooHigh(format!(
                "user {uid} would have {} pixels a second drawn ({user_rate} open and {rate} \
                 asked), over the most one user may (max-pixel-rate-per-user = {})",
                user_rate + rate,
                self.max_pixel_rate_per_user
            )));
        }
        if asked.shared {
            return Ok(());
        }
        let total_rate: u64 = drawn.iter().map(|r| pixel_rate(r)).sum();
        if total_rate + rate > self.max_pixel_rate {
            return Err(Error::PixelRateTooHigh(format!(
                "the renderer would draw {} pixels a second ({total_rate} open and {rate} \
                 asked), over the most it draws for everyone (max-pixel-rate = {})",
                total_rate + rate,
                self.max_pixel_rate
            )));
        }
        let mib = |bytes: u64| bytes as f64 / f64::from(1 << 20);
        let memory: u64 = drawn.iter().map(|r| ring_bytes(r.size)).sum();
        let needed = ring_bytes(asked.request.size);
        if memory + needed > self.max_stream_memory << 20 {
            return Err(Error::TooMuchMemory(format!(
                "the streams' rings hold {:.1} MiB and this one needs {:.1} MiB more, over \
                 the most they may hold (max-stream-memory = {} MiB)",
                mib(memory),
                mib(needed),
                self.max_stream_memory
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::options::View;

    fn request(width: u32, height: u32, rate: f64) -> Request {
        Request {
            size: (width, height),
            view: View::default(),
            rate,
        }
    }

    fn asked<'a>(owner: &'a str, uid: u32, request: &'a Request) -> Asked<'a> {
        Asked {
            owner,
            uid,
            request,
            shared: false,
        }
    }

    /// The limits of a command line with `args`.
    fn parsed(args: &[&str]) -> Result<Limits, clap::Error> {
        #[derive(clap::Parser)]
        struct Line {
            #[command(flatten)]
            limits: Limits,
        }
        let line = std::iter::once("hapticd-render").chain(args.iter().copied());
        <Line as clap::Parser>::try_parse_from(line).map(|l| l.limits)
    }

    fn defaults() -> Limits {
        parsed(&[]).unwrap()
    }

    #[test]
    fn limits_are_read_from_the_command_line_and_zero_is_refused() {
        assert_eq!(defaults().max_streams_per_caller, 4);
        assert_eq!(defaults().max_pixel_rate, 2 * 1920 * 1080 * 60);
        assert_eq!(parsed(&["--max-streams=3"]).unwrap().max_streams, 3);
        let zero = parsed(&["--max-streams=0"]).unwrap_err().to_string();
        assert!(zero.contains("--max-streams"), "{zero}");
        assert!(parsed(&["--max-pixel-rate=lots"]).is_err());
    }

    #[test]
    fn a_frame_over_the_pixels_of_one_is_refused_by_name() {
        let limits = defaults();
        assert!(limits.check_frame(&request(3840, 2160, 30.0)).is_ok());
        let error = limits.check_frame(&request(8192, 8192, 30.0)).unwrap_err();
        assert!(
            matches!(&error, Error::FrameTooLarge(m) if m.contains("max-frame-pixels = 8294400")),
            "{error:?}"
        );
    }

    #[test]
    fn streams_are_counted_by_connection_by_user_and_in_all() {
        let limits = Limits {
            max_streams_per_caller: 2,
            max_streams_per_user: 3,
            max_streams: 4,
            ..defaults()
        };
        let small = request(64, 48, 1.0);
        let held = |pairs: &[(&'static str, u32)]| -> Vec<Held<'_>> {
            pairs
                .iter()
                .map(|&(owner, uid)| Held {
                    owner,
                    uid,
                    request: &small,
                })
                .collect()
        };
        let refused = |open: &[Held], who: Asked| match limits.check_stream(&who, open, &[]) {
            Err(Error::TooManyStreams(m)) => m,
            other => panic!("{other:?}"),
        };
        let two = held(&[(":1.1", 1000), (":1.1", 1000)]);
        assert!(refused(&two, asked(":1.1", 1000, &small)).contains("max-streams-per-caller = 2"));
        // Another connection of the same user gets one more, then the user's limit.
        assert!(
            limits
                .check_stream(&asked(":1.2", 1000, &small), &two, &[])
                .is_ok()
        );
        let three = held(&[(":1.1", 1000), (":1.1", 1000), (":1.2", 1000)]);
        let message = refused(&three, asked(":1.3", 1000, &small));
        assert!(message.contains("user 1000 has 3"), "{message}");
        assert!(message.contains("max-streams-per-user = 3"), "{message}");
        assert!(
            limits
                .check_stream(&asked(":1.4", 0, &small), &three, &[])
                .is_ok()
        );
        let four = held(&[(":1.1", 1000), (":1.1", 1000), (":1.2", 1000), (":1.4", 0)]);
        assert!(refused(&four, asked(":1.5", 2000, &small)).contains("max-streams = 4"));
    }

    #[test]
    fn pixel_rates_are_counted_by_user_and_drawings_once_in_all() {
        let limits = Limits {
            max_pixel_rate_per_user: 1920 * 1080 * 60,
            max_pixel_rate: 1920 * 1080 * 90,
            ..defaults()
        };
        let full_hd = request(1920, 1080, 60.0);
        let half = request(1920, 1080, 30.0);
        let error = limits
            .check_stream(&asked(":1.1", 7, &request(3840, 2160, 30.0)), &[], &[])
            .unwrap_err();
        assert!(
            matches!(&error, Error::PixelRateTooHigh(m)
                if m.contains("max-pixel-rate-per-user = 124416000")),
            "{error:?}"
        );
        let mine = [Held {
            owner: ":1.1",
            uid: 7,
            request: &full_hd,
        }];
        assert!(matches!(
            limits.check_stream(&asked(":1.2", 7, &half), &mine, &[&full_hd]),
            Err(Error::PixelRateTooHigh(_))
        ));
        // Another user's half-rate stream passes the total; a second one of its own would not
        // pass the total, unless it is the same picture, which is drawn once already.
        let theirs = asked(":1.3", 8, &half);
        assert!(limits.check_stream(&theirs, &mine, &[&full_hd]).is_ok());
        let both = [
            mine[0],
            Held {
                owner: ":1.3",
                uid: 8,
                request: &half,
            },
        ];
        let other = request(1920, 1080, 31.0);
        let error = limits
            .check_stream(&asked(":1.4", 9, &other), &both, &[&full_hd, &half])
            .unwrap_err();
        assert!(
            matches!(&error, Error::PixelRateTooHigh(m) if m.contains("max-pixel-rate = ")),
            "{error:?}"
        );
        let same = Asked {
            shared: true,
            ..asked(":1.4", 9, &half)
        };
        assert!(
            limits
                .check_stream(&same, &both, &[&full_hd, &half])
                .is_ok()
        );
    }

    #[test]
    fn tiny_frames_are_charged_their_fixed_cost() {
        assert_eq!(pixel_rate(&request(1, 1, 10.0)), FRAME_FLOOR * 10);
        assert_eq!(pixel_rate(&request(640, 480, 2.5)), 640 * 480 * 5 / 2);
    }

    #[test]
    fn the_rings_memory_is_bounded() {
        let limits = Limits {
            max_stream_memory: 64,
            ..defaults()
        };
        let frame = request(1920, 1080, 1.0);
        // Three frames of full HD are 23.7 MiB: two rings fit in 64 MiB, a third does not.
        let open = [&frame, &frame];
        let error = limits
            .check_stream(&asked(":1.1", 1, &frame), &[], &open)
            .unwrap_err();
        assert!(
            matches!(&error, Error::TooMuchMemory(m) if m.contains("max-stream-memory = 64 MiB")),
            "{error:?}"
        );
        assert!(
            limits
                .check_stream(&asked(":1.1", 1, &frame), &[], &open[..1])
                .is_ok()
        );
    }
}
