//! A private nginx serving the Bazel HTTP cache protocol on loopback, for the remote-cache
//! tests and benchmark (`tests/fixtures/nginx-remote-cache.conf`).

use std::net::{TcpListener, TcpStream};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use super::repo;

/// A private nginx on a free loopback port, stopped when dropped.
pub struct Nginx {
    pub dir: tempfile::TempDir,
    pub port: u16,
    bin: &'static str,
    child: Option<Child>,
}

/// The bearer token `/private/` wants.
pub const TOKEN: &str = "t0ken-never-printed";

impl Nginx {
    /// The tests build many scenes each; one at a time keeps memory and timings sane.
    pub fn start() -> Option<(Nginx, std::sync::MutexGuard<'static, ()>)> {
        static ONE: std::sync::Mutex<()> = std::sync::Mutex::new(());
        let guard = ONE.lock().unwrap_or_else(|e| e.into_inner());
        let Some(bin) = ["nginx", "/usr/sbin/nginx"].into_iter().find(|b| {
            Command::new(b).arg("-v").stdout(Stdio::null()).stderr(Stdio::null()).status().is_ok_and(|s| s.success())
        }) else {
            assert!(std::env::var_os("TESSERA_REQUIRE_NGINX").is_none(), "no nginx on the PATH");
            eprintln!("SKIPPED: no nginx (`apt-get install nginx-light`)");
            return None;
        };
        let dir = tempfile::tempdir().expect("tempdir");
        let port = TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port();
        for sub in ["data", "damaged", "tmp"] {
            std::fs::create_dir_all(dir.path().join(sub)).expect("mkdir");
        }
        // nginx's workers may run as another user (as root, `nobody`): let them write.
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(dir.path().join("data"), std::fs::Permissions::from_mode(0o777)).expect("chmod");
        let conf = std::fs::read_to_string(repo().join("tests/fixtures/nginx-remote-cache.conf"))
            .expect("config")
            .replace("@DIR@", dir.path().to_str().expect("utf-8"))
            .replace("@PORT@", &port.to_string())
            .replace("@TOKEN@", TOKEN);
        std::fs::write(dir.path().join("nginx.conf"), conf).expect("write config");
        let mut server = Nginx { dir, port, bin, child: None };
        server.restart();
        Some((server, guard))
    }

    /// Starts the server, again after [`Nginx::kill`]: the same port, the same stored files.
    pub fn restart(&mut self) {
        assert!(self.child.is_none(), "nginx is running");
        let dir = self.dir.path();
        use std::os::unix::process::CommandExt;
        let child = Command::new(self.bin)
            .process_group(0)
            .arg("-p")
            .arg(dir)
            .arg("-e")
            .arg(dir.join("error.log"))
            .arg("-c")
            .arg(dir.join("nginx.conf"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("start nginx");
        self.child = Some(child);
        let start = Instant::now();
        while TcpStream::connect(("127.0.0.1", self.port)).is_err() {
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "nginx did not start: {:?}",
                std::fs::read_to_string(dir.join("error.log"))
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    pub fn url(&self, location: &str) -> String {
        format!("http://127.0.0.1:{}/{location}", self.port)
    }

    /// The files the server holds for `/cache/`.
    pub fn stored(&self) -> Vec<PathBuf> {
        let mut files = Vec::new();
        for area in ["ac", "cas"] {
            for e in std::fs::read_dir(self.dir.path().join("data/cache").join(area)).into_iter().flatten().flatten() {
                files.push(e.path());
            }
        }
        files
    }

    pub fn access_log(&self) -> String {
        std::fs::read_to_string(self.dir.path().join("access.log")).unwrap_or_default()
    }

    /// Kills the server at once, master and workers (its own process group), with no
    /// graceful close of open connections.
    pub fn kill(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = Command::new("kill").arg("-KILL").arg("--").arg(format!("-{}", c.id())).status();
            let _ = c.wait();
        }
    }
}

impl Drop for Nginx {
    fn drop(&mut self) {
        self.kill();
    }
}
