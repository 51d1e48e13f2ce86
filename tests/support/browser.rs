//! A real headless browser for the dashboard tests: Debian's `chromium`, driven through
//! `chromedriver` (WebDriver, with the fantoccini client) that the test starts on a free
//! 127.0.0.1 port with a fresh profile. Both come from `scripts/install-test-tools.sh`; when
//! either is missing, [`require_browser`] fails the test under `CI` and skips it loudly
//! otherwise (see [`crate::tools`]). The driver runs in its own process group, so a failing
//! test's guard kills the browser it started with it.

use crate::{Scratch, tools};
use fantoccini::{Client, ClientBuilder, Locator};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The chromium and chromedriver executables.
#[derive(Debug, Clone)]
pub struct BrowserTools {
    /// `chromium`.
    pub chromium: PathBuf,
    /// `chromedriver`.
    pub chromedriver: PathBuf,
}

/// The browser's tools, or `None` (after saying so loudly) when the test is to be skipped.
pub fn require_browser(test: &str) -> Option<BrowserTools> {
    let chromium = tools::require("chromium", test)?;
    let chromedriver = tools::require("chromedriver", test)?;
    Some(BrowserTools {
        chromium,
        chromedriver,
    })
}

/// The flags chromium runs with: headless, no sandbox (tests run as root in containers), and
/// nothing that reaches out to the network on its own.
pub const CHROMIUM_FLAGS: &[&str] = &[
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-dev-shm-usage",
    "--window-size=1280,1000",
];

/// A chromedriver process group, killed on drop.
#[derive(Debug)]
struct DriverGuard(Child);

impl Drop for DriverGuard {
    fn drop(&mut self) {
        let group = format!("-{}", self.0.id());
        let _ = Command::new("kill").args(["-KILL", "--", &group]).status();
        let _ = self.0.wait();
    }
}

/// A browser session. Call [`Browser::close`] at the end; dropping it kills the driver and
/// the browser anyway.
#[derive(Debug)]
pub struct Browser {
    /// The WebDriver session.
    pub client: Client,
    _driver: DriverGuard,
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

impl Browser {
    /// Starts chromedriver and a fresh chromium session; its logs and profile go under
    /// `scratch`.
    pub async fn start(tools: &BrowserTools, scratch: &Scratch) -> Browser {
        use std::os::unix::process::CommandExt;
        let port = free_port();
        let log = std::fs::File::create(scratch.join("chromedriver.log")).expect("a log file");
        let driver = Command::new(&tools.chromedriver)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(log)
            .process_group(0)
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {}: {e}", tools.chromedriver.display()));
        let driver = DriverGuard(driver);
        let url = format!("http://127.0.0.1:{port}");
        let deadline = Instant::now() + Duration::from_secs(20);
        while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(
                Instant::now() < deadline,
                "chromedriver did not listen on {port}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        let profile = scratch.join("chromium-profile");
        let mut args: Vec<String> = CHROMIUM_FLAGS.iter().map(|f| f.to_string()).collect();
        args.push(format!("--user-data-dir={}", profile.display()));
        let mut capabilities = serde_json::Map::new();
        capabilities.insert("browserName".into(), json!("chrome"));
        capabilities.insert(
            "goog:chromeOptions".into(),
            json!({ "binary": path_string(&tools.chromium), "args": args }),
        );
        let connector = hyper_util::client::legacy::connect::HttpConnector::new();
        let client = ClientBuilder::new(connector)
            .capabilities(capabilities)
            .connect(&url)
            .await
            .unwrap_or_else(|e| {
                panic!(
                    "cannot start a chromium session: {e}; chromedriver's log:\n{}",
                    std::fs::read_to_string(scratch.join("chromedriver.log")).unwrap_or_default()
                )
            });
        Browser {
            client,
            _driver: driver,
        }
    }

    /// Opens `url`.
    pub async fn goto(&self, url: &str) {
        self.client
            .goto(url)
            .await
            .unwrap_or_else(|e| panic!("cannot open {url}: {e}"));
    }

    /// The page's visible text.
    pub async fn text(&self) -> String {
        self.eval("return document.body ? document.body.innerText : '';")
            .await
            .as_str()
            .unwrap_or_default()
            .to_string()
    }

    /// Runs `script` in the page and returns its value.
    pub async fn eval(&self, script: &str) -> Value {
        self.client
            .execute(script, Vec::new())
            .await
            .unwrap_or_else(|e| panic!("script failed: {e}\n{script}"))
    }

    /// Waits until `script` returns something truthy, at most `timeout`; returns the value.
    pub async fn wait_for(&self, what: &str, script: &str, timeout: Duration) -> Value {
        let deadline = Instant::now() + timeout;
        loop {
            // A page that is being reloaded answers with an error; try again.
            if let Ok(value) = self.client.execute(script, Vec::new()).await {
                let truthy = match &value {
                    Value::Null => false,
                    Value::Bool(b) => *b,
                    Value::Number(n) => n.as_f64() != Some(0.0),
                    Value::String(s) => !s.is_empty(),
                    _ => true,
                };
                if truthy {
                    return value;
                }
            }
            if Instant::now() > deadline {
                let text = self.text().await;
                panic!("timed out after {timeout:?} waiting for {what}; the page says:\n{text}");
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    }

    /// Signs in through the login form at `base_url` with `token`; returns the text of the
    /// page it leads to (the job list, or the form again saying why).
    pub async fn sign_in(&self, base_url: &str, token: &str) -> String {
        self.goto(&format!("{base_url}/login")).await;
        let field = self
            .client
            .find(Locator::Css("form.login input[name=token]"))
            .await
            .expect("the login form has a token field");
        field.send_keys(token).await.expect("typing the token");
        self.client
            .find(Locator::Css("form.login button[type=submit]"))
            .await
            .expect("the login form has a button")
            .click()
            .await
            .expect("submitting the login form");
        self.wait_for(
            "the page after signing in",
            "return document.readyState === 'complete' && (!document.querySelector('form.login') || !!document.querySelector('.error-message'));",
            Duration::from_secs(10),
        )
        .await;
        self.text().await
    }

    /// Ends the session and the browser.
    pub async fn close(self) {
        let _ = self.client.close().await;
    }
}

fn path_string(path: &Path) -> String {
    path.to_string_lossy().into_owned()
}
