//! A throwaway PostgreSQL server for the tests: `initdb` into a temporary directory, `postgres`
//! on a free TCP port of 127.0.0.1 (and a Unix socket in that directory), stopped and removed
//! when the [`Server`] is dropped.
//!
//! Tests run as root in CI, and PostgreSQL refuses to run as root: then the server runs as the
//! unprivileged user `nobody` (`runuser -u nobody --`), owning the temporary directory.
//!
//! The binaries are found in `PATH`, else in `/usr/lib/postgresql/<version>/bin` (Debian). If
//! there are none, [`Server::start`] prints a loud message and returns `None` (the test
//! skips) — unless `SAVME_REQUIRE_POSTGRES=1`, when it panics (CI sets it).
//!
//! [`Server::start_tls`] starts one that accepts TCP connections only over TLS, with the
//! certificate and key given. The harness itself connects over the Unix socket (trusted).
#![allow(dead_code)]

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

/// The superuser's password (connections over TCP need it: the tests exercise password
/// authentication and check it never leaks).
pub const PASSWORD: &str = "s3cret-Pa55word-xyzzy";
/// The superuser.
pub const USER: &str = "savme";

/// A running throwaway server.
pub struct Server {
    bin: PathBuf,
    dir: PathBuf,
    port: u16,
    child: Option<Child>,
    as_nobody: bool,
    tls: bool,
    /// Commits wait for the disk (fsync on, synchronous_commit on), as a production server's;
    /// the tests' servers skip fsync.
    durable: bool,
}

/// The directory holding `initdb`, `postgres` and `pg_ctl`, if any.
fn find_bin() -> Option<PathBuf> {
    let has = |d: &Path| d.join("initdb").is_file() && d.join("postgres").is_file();
    if let Some(path) = std::env::var_os("PATH") {
        if let Some(d) = std::env::split_paths(&path).find(|d| has(d)) {
            return Some(d);
        }
    }
    let mut versions: Vec<PathBuf> = std::fs::read_dir("/usr/lib/postgresql")
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path().join("bin"))
        .filter(|d| has(d))
        .collect();
    versions.sort();
    versions.pop()
}

fn running_as_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
        .unwrap_or(false)
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("no free TCP port on 127.0.0.1")
}

impl Server {
    /// Starts a new server, or returns `None` (after a loud message) when PostgreSQL is not
    /// installed and `SAVME_REQUIRE_POSTGRES` is not `1`.
    pub fn start(test: &str) -> Option<Server> {
        Server::start_with(test, None)
    }

    /// [`Server::start`] with **durable commits** (`fsync=on`, `synchronous_commit=on`, the
    /// PostgreSQL defaults) and room for 200 connections: for benchmarks.
    pub fn start_durable(test: &str) -> Option<Server> {
        let mut s = Server::start_with(test, None)?;
        s.durable = true;
        s.stop();
        s.run();
        Some(s)
    }

    /// [`Server::start`], the server accepting TCP connections only over TLS (`hostssl` in
    /// `pg_hba.conf`, anything else rejected) with the PEM certificate (chain) and key given.
    pub fn start_tls(test: &str, cert: &Path, key: &Path) -> Option<Server> {
        Server::start_with(test, Some((cert, key)))
    }

    // Long because it is one recipe: the directory, initdb, the TLS set-up, the start.
    fn start_with(test: &str, tls: Option<(&Path, &Path)>) -> Option<Server> {
        let Some(bin) = find_bin() else {
            let message =
                "no PostgreSQL binaries (initdb, postgres) in PATH or /usr/lib/postgresql/*/bin";
            if std::env::var("SAVME_REQUIRE_POSTGRES").as_deref() == Ok("1") {
                panic!("{message}, and SAVME_REQUIRE_POSTGRES=1");
            }
            eprintln!("\n!!!!!!!!!! SKIPPED {test}: {message} — install PostgreSQL (Debian: apt-get install postgresql) !!!!!!!!!!\n");
            return None;
        };
        static COUNT: AtomicU32 = AtomicU32::new(0);
        // The directory holds the Unix socket the harness connects through: keep its name to
        // characters a connection string takes as they are.
        let name: String = test
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '_' {
                    c
                } else {
                    '-'
                }
            })
            .collect();
        let dir = std::env::temp_dir().join(format!(
            "savme-pg-{}-{}-{name}",
            std::process::id(),
            COUNT.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let as_nobody = running_as_root();
        let pwfile = dir.join("pw");
        std::fs::write(&pwfile, format!("{PASSWORD}\n")).unwrap();
        if as_nobody {
            let ok = Command::new("chown")
                .args(["-R", "nobody:nogroup"])
                .arg(&dir)
                .status()
                .unwrap()
                .success();
            assert!(ok, "chown of {} to nobody failed", dir.display());
        }
        let mut server = Server {
            bin,
            dir,
            port: free_port(),
            child: None,
            as_nobody,
            tls: tls.is_some(),
            durable: false,
        };
        let data = server.dir.join("data");
        let out = server
            .command("initdb")
            .arg("-D")
            .arg(&data)
            .args(["-U", USER, "-N", "-E", "UTF8", "--locale=C"])
            .args(["--auth-local=trust", "--auth-host=scram-sha-256"])
            .arg(format!("--pwfile={}", pwfile.display()))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "initdb failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        if let Some((cert, key)) = tls {
            server.set_up_tls(cert, key);
        }
        // A free port can be taken by another test's server between our probe and its bind:
        // then try another.
        for _ in 0..5 {
            if server.try_run() {
                return Some(server);
            }
            server.port = free_port();
        }
        panic!("postgres did not start on 5 ports: {}", server.log());
    }

    /// Copies the certificate and key into the data directory (the key readable by the server
    /// only, as it demands) and makes TCP connections TLS-only.
    fn set_up_tls(&self, cert: &Path, key: &Path) {
        let data = self.dir.join("data");
        std::fs::copy(cert, data.join("server.crt")).unwrap();
        std::fs::copy(key, data.join("server.key")).unwrap();
        let hba = "local all all trust\nhostssl all all 127.0.0.1/32 scram-sha-256\nhost all all 127.0.0.1/32 reject\n";
        std::fs::write(data.join("pg_hba.conf"), hba).unwrap();
        let mut files = vec![data.join("server.crt"), data.join("server.key")];
        files.push(data.join("pg_hba.conf"));
        if self.as_nobody {
            let ok = Command::new("chown")
                .arg("nobody:nogroup")
                .args(&files)
                .status()
                .unwrap()
                .success();
            assert!(ok, "chown of the TLS files failed");
        }
        let ok = Command::new("chmod")
            .arg("600")
            .arg(data.join("server.key"))
            .status()
            .unwrap()
            .success();
        assert!(ok, "chmod of the key failed");
    }

    /// A command running `program` of the PostgreSQL binaries, as `nobody` when we are root.
    fn command(&self, program: &str) -> Command {
        let exe = self.bin.join(program);
        if self.as_nobody {
            let mut c = Command::new("runuser");
            c.args(["-u", "nobody", "--"]).arg(exe);
            c
        } else {
            Command::new(exe)
        }
    }

    /// Starts `postgres` on the data directory and waits until it accepts connections.
    fn run(&mut self) {
        assert!(self.try_run(), "postgres exited: {}", self.log());
    }

    /// [`Server::run`]; false if the server exited at once (its port was taken).
    fn try_run(&mut self) -> bool {
        let log = std::fs::File::create(self.dir.join("server.log")).unwrap();
        let child = self
            .command("postgres")
            .arg("-D")
            .arg(self.dir.join("data"))
            .arg("-k")
            .arg(&self.dir)
            .args(["-p", &self.port.to_string()])
            .args(["-c", "listen_addresses=127.0.0.1"])
            .args(match self.durable {
                true => ["-c", "fsync=on", "-c", "synchronous_commit=on"],
                false => ["-c", "fsync=off", "-c", "synchronous_commit=on"],
            })
            // Light: several servers run at once (one per test), and CI containers may have a
            // small /dev/shm.
            .args(match self.durable {
                true => ["-c", "max_connections=200", "-c", "shared_buffers=64MB"],
                false => ["-c", "max_connections=60", "-c", "shared_buffers=16MB"],
            })
            .args(["-c", "dynamic_shared_memory_type=mmap"])
            .args(if self.tls { &["-c", "ssl=on"][..] } else { &[] })
            .stdin(Stdio::null())
            .stdout(log.try_clone().unwrap())
            .stderr(log)
            .spawn()
            .unwrap();
        self.child = Some(child);
        let deadline = Instant::now() + Duration::from_secs(60);
        loop {
            if let Some(Ok(Some(_))) = self.child.as_mut().map(|c| c.try_wait()) {
                self.child = None;
                return false;
            }
            // Ours, not another test's server that took the port first.
            let data = self.dir.join("data").display().to_string();
            let ours = postgres::Client::connect(&self.socket_url(), postgres::NoTls)
                .and_then(|mut c| c.query_one("SHOW data_directory", &[]))
                .map(|r| r.get::<_, String>(0) == data);
            match ours {
                Ok(true) => return true,
                Ok(false) => {
                    self.stop();
                    return false;
                }
                Err(_) => {}
            }
            assert!(
                Instant::now() < deadline,
                "postgres did not accept connections within 60 s: {}",
                self.log()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// The server's log so far.
    pub fn log(&self) -> String {
        std::fs::read_to_string(self.dir.join("server.log")).unwrap_or_default()
    }

    /// The superuser's URL (with the password), database `postgres`.
    pub fn url(&self) -> String {
        self.url_for(USER, PASSWORD, "postgres")
    }

    /// A URL for `user` with `password` on database `db`.
    pub fn url_for(&self, user: &str, password: &str, db: &str) -> String {
        format!(
            "postgresql://{user}:{password}@127.0.0.1:{}/{db}",
            self.port
        )
    }

    /// The superuser on database `postgres` over the Unix socket (trusted: no password, no
    /// TLS), for the harness's own connections.
    fn socket_url(&self) -> String {
        format!(
            "host={} port={} user={USER} dbname=postgres",
            self.dir.display(),
            self.port
        )
    }

    /// The postmaster's process id (benchmarks add up the server's CPU time from it).
    pub fn postmaster_pid(&self) -> Option<u32> {
        std::fs::read_to_string(self.dir.join("data/postmaster.pid"))
            .ok()?
            .lines()
            .next()?
            .trim()
            .parse()
            .ok()
    }

    /// The TCP port.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// A new database (its name), so that tests sharing nothing can share a server.
    pub fn create_db(&self, name: &str) -> String {
        let mut c = self.client();
        c.batch_execute(&format!("CREATE DATABASE \"{name}\""))
            .unwrap();
        self.url_for(USER, PASSWORD, name)
    }

    /// A superuser connection (over the Unix socket).
    pub fn client(&self) -> postgres::Client {
        postgres::Client::connect(&self.socket_url(), postgres::NoTls).unwrap()
    }

    /// A superuser connection to database `db` (over the Unix socket).
    pub fn client_of(&self, db: &str) -> postgres::Client {
        let url = self
            .socket_url()
            .replace("dbname=postgres", &format!("dbname={db}"));
        postgres::Client::connect(&url, postgres::NoTls).unwrap()
    }

    /// Stops the server (fast shutdown: sessions are ended) and waits for it.
    pub fn stop(&mut self) {
        let Some(mut child) = self.child.take() else {
            return;
        };
        // The postmaster's pid is the first line of postmaster.pid (the child may be runuser).
        let pid = std::fs::read_to_string(self.dir.join("data/postmaster.pid"))
            .ok()
            .and_then(|t| t.lines().next().map(str::to_string));
        match pid {
            Some(pid) => {
                let _ = Command::new("kill").args(["-INT", &pid]).status();
            }
            None => {
                let _ = child.kill();
            }
        }
        let deadline = Instant::now() + Duration::from_secs(30);
        while Instant::now() < deadline {
            if let Ok(Some(_)) = child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = child.kill();
        let _ = child.wait();
    }

    /// Stops the server as a crash would (`pg_ctl stop -m immediate`: SIGQUIT to the
    /// postmaster — no checkpoint, and what the write-ahead log had not written yet is lost;
    /// the next start recovers), then starts it again.
    pub fn crash_and_restart(&mut self) {
        let pid = std::fs::read_to_string(self.dir.join("data/postmaster.pid"))
            .ok()
            .and_then(|t| t.lines().next().map(str::to_string))
            .expect("the postmaster's pid");
        let ok = Command::new("kill").args(["-QUIT", &pid]).status().unwrap();
        assert!(ok.success());
        if let Some(mut child) = self.child.take() {
            let _ = child.wait();
        }
        self.run();
    }

    /// Starts the stopped server again (same data, same port).
    pub fn restart(&mut self) {
        self.stop();
        self.run();
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.stop();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}
