//! Opening a scan file, gzip'd or not (detected by content): a gzip'd file is inflated a few
//! 1 MiB blocks ahead, on a thread of its own ([`ReadAhead`]), since inflating takes about as long
//! as parsing the text it gives: inflated in place instead, the dragon's `kiosk import` takes
//! 1.16 times as long (21 runs of each side by side, stores identical; docs/performance.md).

use std::io::{BufRead, BufReader};
use std::path::Path;

/// Opens a file, unwrapping gzip when its first bytes say so (inflated on a thread of its own,
/// ahead of the reader: inflating takes about as long as parsing the text it gives).
pub fn open(path: &Path) -> std::io::Result<Box<dyn BufRead + Send>> {
    let mut f = BufReader::with_capacity(1 << 20, std::fs::File::open(path)?);
    let gz = f.fill_buf()?.starts_with(&[0x1f, 0x8b]);
    Ok(if gz { ReadAhead::start(Inflate(flate2::bufread::MultiGzDecoder::new(f))) } else { Box::new(f) })
}

/// The gzip decoder, whose own errors ("incomplete deflate stream") say that the compressed file
/// is at fault, not the text in it (as data errors: a cut-short stream is not the end of the text
/// that a reader counting rows would report). The file's I/O errors pass as they are.
struct Inflate<R>(R);

impl<R: std::io::Read> std::io::Read for Inflate<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        use std::io::ErrorKind::{InvalidData, InvalidInput, UnexpectedEof};
        self.0.read(buf).map_err(|e| match e.kind() {
            InvalidData | InvalidInput | UnexpectedEof => std::io::Error::new(
                InvalidData,
                format!("gzip: {e} (the compressed file is damaged or cut short)"),
            ),
            _ => e,
        })
    }
}

/// A reader read on a thread of its own, a few blocks ahead of its consumer. A failure comes
/// after the bytes read before it; the thread stops when the consumer is dropped. The end of
/// the input is an empty block: a thread that stops without one (a panic) is an error, not an
/// input cut short.
pub(crate) struct ReadAhead {
    blocks: std::sync::mpsc::Receiver<std::io::Result<Vec<u8>>>,
    /// Blocks consumed, for the thread to fill again.
    spare: std::sync::mpsc::Sender<Vec<u8>>,
    block: Vec<u8>,
    at: usize,
    /// The empty block came.
    ended: bool,
}

impl ReadAhead {
    /// Bytes per block.
    const BLOCK: usize = 1 << 20;

    /// Reads `inner` ahead, or in place if the system refuses a thread.
    pub(crate) fn start(inner: impl std::io::Read + Send + 'static) -> Box<dyn BufRead + Send> {
        let (tx, blocks) = std::sync::mpsc::sync_channel(2);
        let (spare, spare_rx) = std::sync::mpsc::channel::<Vec<u8>>();
        let (inner_tx, inner_rx) = std::sync::mpsc::channel();
        let spawned = std::thread::Builder::new().name("read ahead".into()).spawn(move || {
            let Ok(mut inner) = inner_rx.recv() else { return };
            loop {
                let mut block = spare_rx.try_recv().unwrap_or_default();
                block.resize(Self::BLOCK, 0);
                let (got, failed) = crate::fill(&mut inner, &mut block);
                block.truncate(got);
                if got > 0 && tx.send(Ok(block)).is_err() {
                    return;
                }
                if let Some(e) = failed {
                    let _ = tx.send(Err(e));
                    return;
                }
                if got < Self::BLOCK {
                    let _ = tx.send(Ok(Vec::new()));
                    return;
                }
            }
        });
        match spawned {
            Ok(_) => {
                inner_tx.send(inner).map_or_else(
                    // The thread is gone already: read in place.
                    |e| Box::new(BufReader::with_capacity(Self::BLOCK, e.0)) as Box<dyn BufRead + Send>,
                    |()| Box::new(Self { blocks, spare, block: Vec::new(), at: 0, ended: false }),
                )
            }
            // `inner` was never handed over.
            Err(_) => Box::new(BufReader::with_capacity(Self::BLOCK, inner)),
        }
    }
}

impl std::io::Read for ReadAhead {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let got = self.fill_buf()?;
        let n = got.len().min(buf.len());
        buf[..n].copy_from_slice(&got[..n]);
        self.consume(n);
        Ok(n)
    }
}

impl BufRead for ReadAhead {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        if self.at == self.block.len() && !self.ended {
            match self.blocks.recv() {
                Ok(Ok(block)) => {
                    self.ended = block.is_empty();
                    let used = std::mem::replace(&mut self.block, block);
                    // The thread may be done: the buffer is then dropped.
                    let _ = self.spare.send(used);
                    self.at = 0;
                }
                Ok(Err(e)) => return Err(e),
                Err(_) => return Err(std::io::Error::other("the thread reading the input stopped")),
            }
        }
        Ok(&self.block[self.at..])
    }

    fn consume(&mut self, n: usize) {
        self.at = (self.at + n).min(self.block.len());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;

    /// Gives `data` in reads of at most `step` bytes, then fails (or ends).
    struct Trickle {
        data: Vec<u8>,
        at: usize,
        step: usize,
        fails: bool,
    }

    impl Read for Trickle {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            if self.at == self.data.len() {
                return if self.fails { Err(std::io::Error::other("the disk went away")) } else { Ok(0) };
            }
            let n = buf.len().min(self.step).min(self.data.len() - self.at);
            buf[..n].copy_from_slice(&self.data[self.at..self.at + n]);
            self.at += n;
            Ok(n)
        }
    }

    #[test]
    fn read_ahead_gives_every_byte_in_order_then_the_failure() {
        let data: Vec<u8> =
            (0..(5 * ReadAhead::BLOCK / 2) as u32).map(|i| (i * 7 + i / 4093) as u8).collect();
        for (len, fails) in
            [(data.len(), true), (data.len(), false), (2 * ReadAhead::BLOCK, false), (0, true), (0, false)]
        {
            let trickle = Trickle { data: data[..len].to_vec(), at: 0, step: 100_003, fails };
            let mut r = ReadAhead::start(trickle);
            let mut got = Vec::new();
            let end = r.read_to_end(&mut got);
            assert!(got == data[..len], "{len} bytes: {} read", got.len());
            match end {
                Err(e) => assert!(fails && e.to_string() == "the disk went away", "{len} bytes: {e}"),
                Ok(n) => assert!(!fails && n == len, "{len} bytes: {n} read, the failure lost"),
            }
        }
    }

    #[test]
    fn a_reading_thread_that_panics_is_an_error_not_the_end_of_the_input() {
        struct Panics;
        impl Read for Panics {
            fn read(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
                panic!("a decoder bug");
            }
        }
        let e = ReadAhead::start(Panics).read_to_end(&mut Vec::new()).expect_err("no end of input");
        assert_eq!(e.to_string(), "the thread reading the input stopped");
    }

    #[test]
    fn a_reader_dropped_early_stops_its_thread() {
        let (tx, rx) = std::sync::mpsc::channel();
        struct Endless(std::sync::mpsc::Sender<()>);
        impl Read for Endless {
            fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
                buf.fill(b'x');
                Ok(buf.len())
            }
        }
        impl Drop for Endless {
            fn drop(&mut self) {
                let _ = self.0.send(());
            }
        }
        let mut r = ReadAhead::start(Endless(tx));
        assert_eq!(r.fill_buf().expect("bytes").first(), Some(&b'x'));
        drop(r);
        // The thread drops its reader when it finds nobody reads on.
        rx.recv_timeout(std::time::Duration::from_secs(60)).expect("the thread stopped");
    }
}
