"""End-to-end in a real headless browser (Debian chromium + chromedriver via
python3-selenium, loopback only): an observer completes a short study by
clicking and by keyboard, reloads mid-study, and the server is SIGKILLed while
an answer is being given and restarted; the database must hold exactly the
answers given, each once.

Usage: browser_e2e.py MUCOSA_CLI WORK_DIR [SCREENSHOT_DIR]
"""
import os
import shutil
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import study_fixture as fx  # noqa: E402

from selenium import webdriver  # noqa: E402  (Debian python3-selenium)
from selenium.webdriver.chrome.service import Service  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.common.keys import Keys  # noqa: E402

cli, work = sys.argv[1], sys.argv[2]
shots = sys.argv[3] if len(sys.argv) > 3 else os.path.join(work, "screenshots")
for exe in ("/usr/bin/chromium", "/usr/bin/chromedriver"):
    if not os.path.exists(exe):
        sys.exit(f"FAIL: {exe} is missing (apt-get install chromium chromium-driver)")
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
os.makedirs(shots, exist_ok=True)
plan_path, plan = fx.make_plan(cli, work, observers=2, seed=4,
                               extra=("--likert", "6", "--series", "4", "--twoafc", "1"))
trials = plan["observers"][0]["trials"]
assert [t["kind"] for t in trials] == ["calibration"] + ["likert"] * 6 + ["twoafc"] * 3, trials
db = os.path.join(work, "answers.sqlite")
srv = fx.Server(cli, plan_path, db)
port = int(srv.base.rsplit(":", 1)[1])
profile = tempfile.mkdtemp(prefix="mucosa-chromium-")

opts = webdriver.ChromeOptions()
opts.binary_location = "/usr/bin/chromium"
for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
          "--disable-background-networking", "--disable-component-update", "--disable-sync",
          "--disable-dev-shm-usage", "--window-size=960,700", f"--user-data-dir={profile}"):
    opts.add_argument(a)
driver = webdriver.Chrome(service=Service(executable_path="/usr/bin/chromedriver"), options=opts)
given = []


token = srv.tokens[0]


def server_trial():
    s, st = fx.request(srv.base, "GET", "/api/state?observer=E2E-1", token=token)
    return st["trial"] if s == 200 else None


def wait(cond, what, timeout=30):
    t0 = time.time()
    while time.time() - t0 < timeout:
        try:
            if cond():
                return
        except Exception:  # noqa: BLE001 - page between states
            pass
        time.sleep(0.05)
    driver.save_screenshot(os.path.join(work, "failed.png"))
    raise AssertionError(f"timed out waiting for {what} (page at {os.path.join(work, 'failed.png')})")


def visible(screen):
    return driver.execute_script(f"return !document.getElementById('screen-{screen}').hidden")


def ready(screen):
    return visible(screen) and driver.execute_script(
        f"return [...document.querySelectorAll('#screen-{screen} button')].every(b => !b.disabled)")


def at(trial, screen):
    wait(lambda: server_trial() == trial and ready(screen), f"screen {trial} ({screen})")
    t = trials[trial]
    src = lambda i: driver.find_element(By.ID, i).get_attribute("src")  # noqa: E731
    if screen == "likert":
        assert src("likert-image").endswith(f"/image/{t['image']}?t={token}"), "page shows the planned image"
    elif screen == "twoafc":
        assert src("afc-left").endswith(f"/image/{t['left']}?t={token}")
        assert src("afc-right").endswith(f"/image/{t['right']}?t={token}")


def shot(name):
    path = os.path.join(shots, f"study_{name}.png")
    driver.save_screenshot(path)
    from PIL import Image  # keep README pictures small: 128-colour palette
    Image.open(path).convert("RGB").quantize(colors=128).save(path, optimize=True)


def key(k):
    driver.find_element(By.TAG_NAME, "body").send_keys(k)


def click(i):
    driver.find_element(By.ID, i).click()


try:
    for bad in ("/", "/?t=" + "0" * 32, "/?t=" + srv.tokens[1][:-2]):  # no, a wrong, a cut link
        driver.get(srv.base + bad)
        wait(lambda: visible("invalid") and not visible("welcome"), f"'link not valid' screen for {bad}")
    shot("invalid_link")
    driver.get(srv.links[0])
    wait(lambda: visible("welcome"), "welcome screen")
    driver.find_element(By.ID, "observer").send_keys("E2E-1")
    click("group-naive")
    shot("welcome")
    click("start")

    at(0, "calibration")
    shot("calibration")
    click("cal-continue")
    given.append("seen")

    at(1, "likert")
    shot("likert")
    click("score-4"); given.append(4)                      # click
    at(2, "likert"); key("2"); given.append(2)            # keyboard
    at(3, "likert"); click("score-5"); given.append(5)
    at(4, "likert"); key("1"); given.append(1)
    wait(lambda: visible("break") and server_trial() == 5, "series break")
    key(Keys.ENTER)
    at(5, "likert")
    driver.refresh()                                       # reload: resumes at the same screen
    wait(lambda: visible("break") or visible("likert"), "page after reload")
    if visible("break"):
        key(Keys.ENTER)
    at(5, "likert"); key("3"); given.append(3)

    at(6, "likert")
    srv.kill()                                             # SIGKILL while the observer answers
    click("score-2"); given.append(2)
    wait(lambda: "retrying" in driver.find_element(By.ID, "message").text, "retry message while down")
    srv = fx.Server(cli, plan_path, db, port=port)
    at(7, "twoafc")                                        # the pending answer got through once
    shot("twoafc")
    key(Keys.ARROW_LEFT); given.append("left")
    at(8, "twoafc"); click("choose-right"); given.append("right")
    at(9, "twoafc"); key(Keys.ARROW_RIGHT); given.append("right")
    wait(lambda: visible("done") and server_trial() == 10, "done screen")
    shot("done")
finally:
    driver.quit()
    shutil.rmtree(profile, ignore_errors=True)
    srv.stop()

rows = fx.db_rows(db, "E2E-1")
expected = fx.expected_rows(plan, 0, given)
if rows != expected:
    print("FAIL: database differs from the answers given")
    for a, b in zip(rows + [None] * 20, expected):
        print("  db", a, "\n  ex", b)
    sys.exit(1)
big = [f for f in os.listdir(shots) if f.startswith("study_") and os.path.getsize(os.path.join(shots, f)) > 150 * 1024]
print(f"browser e2e passed: {len(rows)} answers stored exactly once; screenshots in {shots}"
      + (f" (over 150 KB: {big})" if big else ""))
