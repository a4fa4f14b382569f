//! The editor's transport: hyper's HTTP/1.1 server on a small tokio runtime (one thread),
//! one task per connection, every request through the [`Gate`] and then to the document's
//! own thread, which runs the handlers ([`super::handle`]) one at a time.
//!
//! Limits (see the threat model in [`super::http`]): hyper's header read timeout and head
//! size cap; the gate's body cap and body deadline; a write timeout on every socket
//! ([`Timed`]); and at most [`MAX_CONNECTIONS`] connections at once, where the oldest
//! connection whose request has not passed the token check is dropped when all are taken.

use super::doc::Doc;
use super::http::{Admitted, Call, Gate, Guard};
use super::{handle, Reply, ServerError};
use hyper::body::Incoming;
use hyper::server::conn::http1;
use hyper_util::rt::{TokioIo, TokioTimer};
use std::collections::BTreeMap;
use std::convert::Infallible;
use std::future::Future;
use std::io;
use std::net::SocketAddr;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc, Mutex};
use std::task::{Context, Poll};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::sync::{oneshot, Semaphore};
use tokio::task::AbortHandle;

/// Connections open at once (default).
pub const MAX_CONNECTIONS: usize = 128;

/// How long `run` waits for work before it checks its stop condition again.
pub const ACCEPT_POLL: Duration = Duration::from_millis(100);

/// Largest read buffer of one connection (bytes): the head and what of the body is in flight.
const READ_BUFFER: usize = 64 << 10;

/// A running editor server.
pub struct Server {
    listener: std::net::TcpListener,
    addr: SocketAddr,
    guard: Guard,
    read_timeout: Duration,
    write_timeout: Duration,
    max_connections: usize,
}

/// A request for the document's thread, and where its answer goes.
struct Job {
    call: Call,
    reply: oneshot::Sender<Reply>,
}

impl Job {
    fn run(self, doc: &mut Doc) {
        let Job { call, reply } = self;
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            handle(doc, &call.method, &call.target, &call.body)
        }))
        .unwrap_or_else(|_| {
            Reply::error(&ServerError::Io("internal error (a bug): see stderr".into()))
        });
        let _ = reply.send(r);
    }
}

impl Server {
    /// Binds `127.0.0.1:port` (`0`: any free port) with a fresh session token.
    pub fn bind(port: u16) -> Result<Server, ServerError> {
        let io = |e: &dyn std::fmt::Display| {
            ServerError::Io(format!("cannot listen on 127.0.0.1:{port}: {e}"))
        };
        let listener = std::net::TcpListener::bind(("127.0.0.1", port)).map_err(|e| io(&e))?;
        listener.set_nonblocking(true).map_err(|e| io(&e))?;
        let addr = listener.local_addr().map_err(|e| io(&e))?;
        let guard = Guard::random(addr.port());
        Ok(Server {
            listener,
            addr,
            guard,
            read_timeout: super::http::READ_TIMEOUT,
            write_timeout: super::http::WRITE_TIMEOUT,
            max_connections: MAX_CONNECTIONS,
        })
    }

    /// The bound address (always on 127.0.0.1).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The session token every `/api/` request must carry ([`super::http`]).
    pub fn token(&self) -> &str {
        self.guard.token()
    }

    /// The page's address with the token (`http://127.0.0.1:P/?token=T`).
    pub fn url(&self) -> String {
        format!("http://{}/?token={}", self.addr, self.guard.token())
    }

    /// Sets the read timeout (for the head, then again for the body) and the write timeout
    /// (defaults [`super::http::READ_TIMEOUT`], [`super::http::WRITE_TIMEOUT`]).
    pub fn with_timeouts(mut self, read: Duration, write: Duration) -> Server {
        self.read_timeout = read;
        self.write_timeout = write;
        self
    }

    /// Sets how many connections may be open at once (default [`MAX_CONNECTIONS`]).
    pub fn with_max_connections(mut self, n: usize) -> Server {
        self.max_connections = n.max(1);
        self
    }

    /// Serves requests until `stop` returns true (checked at least every [`ACCEPT_POLL`]).
    /// The network runs on its own thread; the handlers run on this one, one request at a
    /// time, so the document is never seen by two requests at once.
    pub fn run(&self, doc: &mut Doc, stop: &dyn Fn() -> bool) {
        let (tx, rx) = mpsc::channel::<Job>();
        let quit = Arc::new(AtomicBool::new(false));
        std::thread::scope(|scope| {
            let net = scope.spawn(|| {
                if let Err(e) = self.serve(tx, quit.clone()) {
                    eprintln!("trimorph editor: the server stopped: {e}");
                }
            });
            while !stop() {
                match rx.recv_timeout(ACCEPT_POLL) {
                    Ok(job) => job.run(doc),
                    Err(mpsc::RecvTimeoutError::Timeout) => {}
                    Err(mpsc::RecvTimeoutError::Disconnected) => break,
                }
            }
            quit.store(true, Ordering::Relaxed);
            let _ = net.join();
        });
    }

    /// The accept loop on a one-thread runtime, until `quit`.
    fn serve(&self, jobs: mpsc::Sender<Job>, quit: Arc<AtomicBool>) -> io::Result<()> {
        let rt = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
        rt.block_on(async {
            let listener = tokio::net::TcpListener::from_std(self.listener.try_clone()?)?;
            let slots = Arc::new(Semaphore::new(self.max_connections));
            let open = Arc::new(Open::default());
            let gate = Arc::new(Gate::new(self.guard.clone(), self.read_timeout));
            while !quit.load(Ordering::Relaxed) {
                // A free slot: when none is, the oldest connection not yet admitted goes.
                let permit = match slots.clone().try_acquire_owned() {
                    Ok(p) => p,
                    Err(_) => {
                        open.evict_oldest();
                        match tokio::time::timeout(ACCEPT_POLL, slots.clone().acquire_owned()).await
                        {
                            Ok(Ok(p)) => p,
                            _ => continue,
                        }
                    }
                };
                let tcp = match tokio::time::timeout(ACCEPT_POLL, listener.accept()).await {
                    Ok(Ok((tcp, _))) => tcp,
                    Ok(Err(_)) => {
                        // Out of descriptors, say: wait a little rather than spin.
                        tokio::time::sleep(ACCEPT_POLL).await;
                        continue;
                    }
                    Err(_) => continue,
                };
                // No Nagle delay: a drag step answers ~100 KB, whose last segment would
                // otherwise wait for the browser's delayed ACK (~40 ms).
                let _ = tcp.set_nodelay(true);
                let id = open.next_id();
                let conn = Connection {
                    gate: gate.clone(),
                    jobs: jobs.clone(),
                    open: open.clone(),
                    id,
                    read_timeout: self.read_timeout,
                    write_timeout: self.write_timeout,
                };
                // The runtime has one thread: the task cannot start (and mark itself
                // admitted) before it is registered below.
                let task = tokio::spawn(async move {
                    let _permit = permit;
                    conn.serve(tcp).await;
                });
                open.register(id, task.abort_handle());
            }
            Ok(())
        })
    }
}

/// The open connections whose request has not passed the token check, oldest first.
#[derive(Default)]
struct Open {
    pending: Mutex<BTreeMap<u64, AbortHandle>>,
    next: std::sync::atomic::AtomicU64,
}

impl Open {
    fn next_id(&self) -> u64 {
        self.next.fetch_add(1, Ordering::Relaxed)
    }
    fn register(&self, id: u64, task: AbortHandle) {
        if !task.is_finished() {
            self.lock().insert(id, task);
        }
    }
    /// The connection passed the token check (or ended): it is no longer dropped for room.
    fn settle(&self, id: u64) {
        self.lock().remove(&id);
    }
    fn evict_oldest(&self) {
        if let Some((_, task)) = self.lock().pop_first() {
            task.abort();
        }
    }
    fn lock(&self) -> std::sync::MutexGuard<'_, BTreeMap<u64, AbortHandle>> {
        self.pending.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// Removes a connection from [`Open`] when its task ends or is aborted.
struct Settle(Arc<Open>, u64);

impl Drop for Settle {
    fn drop(&mut self) {
        self.0.settle(self.1);
    }
}

/// One connection's share of the server.
struct Connection {
    gate: Arc<Gate>,
    jobs: mpsc::Sender<Job>,
    open: Arc<Open>,
    id: u64,
    read_timeout: Duration,
    write_timeout: Duration,
}

/// hyper's HTTP/1.1 server with the editor's limits: one request per connection. A client
/// may close its sending side once its request is out (half close) and still get the answer.
fn http1_builder(read_timeout: Duration) -> http1::Builder {
    let mut b = http1::Builder::new();
    b.timer(TokioTimer::new())
        .half_close(true)
        .header_read_timeout(read_timeout)
        .keep_alive(false)
        .title_case_headers(true)
        .auto_date_header(false)
        .max_header_size(super::http::MAX_HEAD)
        .max_buf_size(READ_BUFFER);
    b
}

impl Connection {
    async fn serve(self, tcp: tokio::net::TcpStream) {
        let _settle = Settle(self.open.clone(), self.id);
        let io = TokioIo::new(Timed::new(tcp, self.write_timeout));
        let Connection { gate, jobs, open, id, read_timeout, .. } = self;
        let service = hyper::service::service_fn(move |req: hyper::Request<Incoming>| {
            let (gate, jobs, open) = (gate.clone(), jobs.clone(), open.clone());
            async move {
                let admitted = |a: Admitted| {
                    if a == Admitted::Api {
                        open.settle(id);
                    }
                };
                let dispatch = |call: Call| async move {
                    let (tx, rx) = oneshot::channel();
                    if jobs.send(Job { call, reply: tx }).is_err() {
                        return Reply::error(&ServerError::Io("the editor is stopping".into()));
                    }
                    rx.await.unwrap_or_else(|_| {
                        Reply::error(&ServerError::Io("the editor is stopping".into()))
                    })
                };
                Ok::<_, Infallible>(gate.answer(req, admitted, dispatch).await)
            }
        });
        let conn = http1_builder(read_timeout).serve_connection(io, service).without_shutdown();
        if let Ok(parts) = conn.await {
            linger(parts.io.into_inner()).await;
        }
    }
}

/// Closes the write side, then reads what the client still sends for a moment (at most
/// twice the body cap): closing with unread input would reset the connection and could
/// lose the answer (a refused request whose body was never read).
async fn linger(mut s: Timed) {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let _ = s.shutdown().await;
    let drain = async {
        let mut sink = vec![0u8; 16 << 10];
        let mut left = 2 * super::MAX_BODY;
        while left > 0 {
            match s.read(&mut sink).await {
                Ok(0) | Err(_) => break,
                Ok(n) => left = left.saturating_sub(n),
            }
        }
    };
    let _ = tokio::time::timeout(Duration::from_millis(200), drain).await;
}

/// A stream whose writes fail when they make no progress for `timeout`.
pub struct Timed {
    inner: tokio::net::TcpStream,
    timeout: Duration,
    stalled: Option<Pin<Box<tokio::time::Sleep>>>,
}

impl Timed {
    fn new(inner: tokio::net::TcpStream, timeout: Duration) -> Timed {
        Timed { inner, timeout, stalled: None }
    }

    /// `Pending` from a write: starts the clock, or fails once it has run out.
    fn wait(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<usize>> {
        let t = self.timeout;
        let sleep = self.stalled.get_or_insert_with(|| Box::pin(tokio::time::sleep(t)));
        match sleep.as_mut().poll(cx) {
            Poll::Ready(()) => Poll::Ready(Err(io::ErrorKind::TimedOut.into())),
            Poll::Pending => Poll::Pending,
        }
    }
}

impl AsyncRead for Timed {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_read(cx, buf)
    }
}

impl AsyncWrite for Timed {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        match Pin::new(&mut self.inner).poll_write(cx, buf) {
            Poll::Pending => self.wait(cx),
            r => {
                self.stalled = None;
                r
            }
        }
    }
    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_flush(cx)
    }
    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_shutdown(cx)
    }
}

/// Serves the raw bytes of one connection (`raw`: what a client sends, then the end of its
/// stream) through the same HTTP/1.1 server, [`Gate`] and handlers as [`Server::run`], in
/// memory, the handlers called here on `doc`; returns the raw answer. For the fuzz target
/// `editor_api` and tests.
pub fn serve_bytes(guard: &Guard, doc: &mut Doc, raw: &[u8]) -> Vec<u8> {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    thread_local! {
        static RT: tokio::runtime::Runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .expect("a tokio runtime");
    }
    let gate = Gate::new(guard.clone(), Duration::from_secs(2));
    let doc = std::cell::RefCell::new(doc);
    let raw = raw.to_vec();
    RT.with(|rt| {
        rt.block_on(async {
            let (client, server) = tokio::io::duplex(64 << 10);
            let (mut from_server, mut to_server) = tokio::io::split(client);
            let writer = tokio::spawn(async move {
                let _ = to_server.write_all(&raw).await;
                let _ = to_server.shutdown().await;
            });
            let reader = tokio::spawn(async move {
                let mut out = Vec::new();
                let _ = from_server.read_to_end(&mut out).await;
                out
            });
            let service = hyper::service::service_fn(|req: hyper::Request<Incoming>| {
                let (gate, doc) = (&gate, &doc);
                async move {
                    let dispatch = |c: Call| async move {
                        let mut d = doc.borrow_mut();
                        handle(&mut d, &c.method, &c.target, &c.body)
                    };
                    Ok::<_, Infallible>(gate.answer(req, |_| {}, dispatch).await)
                }
            });
            let conn = http1_builder(Duration::from_secs(2))
                .serve_connection(TokioIo::new(server), service);
            let _ = conn.await;
            let out = reader.await.unwrap_or_default();
            writer.abort();
            out
        })
    })
}
