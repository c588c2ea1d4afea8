// The live view's pages in a real browser against the whole simulated appliance (ioct-rt,
// ioct-gpu, ioct-view as processes): the surgeon's page shows live frames that change, the
// assistant's controls change the next frame's pixels, the STALE banner comes and goes with the
// scan, a viewer without the token changes nothing, and screenshots are kept as artefacts.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "ioct/devtools/headless_chromium.hpp"
#include "ioct/view_test/live_appliance.hpp"

namespace ioct::view_test {
namespace {

using devtools::BrowserPage;
using devtools::HeadlessChromium;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

const std::filesystem::path kArtefacts = IOCT_VIEW_TEST_OUTPUT_DIR;

// The page is live and has drawn at least `frames` frames.
std::string live_with_frames(int frames) {
  return "window.ioctView && ioctView.status.signal === 'live' && ioctView.status.framesDrawn >= " +
         std::to_string(frames) + " && document.getElementById('signal-banner').hidden";
}

// What the render canvas shows now: a hash of its pixels, their mean, and the frame drawn.
constexpr const char* kRenderPixels = R"((() => {
  const c = document.getElementById('render');
  const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
  let hash = 0, sum = 0;
  for (let i = 0; i < d.length; i += 4) {
    hash = (Math.imul(hash, 31) + d[i] + 7 * d[i + 1] + 13 * d[i + 2]) >>> 0;
    sum += d[i] + d[i + 1] + d[i + 2];
  }
  const f = ioctView.status.lastFrame;
  return { hash, mean: sum / (d.length / 4 * 3), width: c.width, height: c.height,
           frame: f.frame, generation: f.generation, mode: f.mode };
})())";

class LiveViewPage : public ::testing::Test {
 protected:
  void SetUp() override {
    // Chromium is part of the project's set-up: without it this fails, it does not skip.
    ASSERT_TRUE(HeadlessChromium::find_executable().has_value())
        << "no Chromium: install the Debian package chromium (tools/setup.sh does)";
    name_ = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    appliance_ = std::make_unique<LiveAppliance>(appliance_options());
    appliance_->start_all();
    devtools::ChromiumOptions options;
    options.window_width = 1280;
    options.window_height = 800;
    options.log_file = kArtefacts / (name_ + "-chromium.log");
    browser_ = std::make_unique<HeadlessChromium>(options);
  }

  void TearDown() override {
    if (!HasFailure()) return;
    if (page_) {
      try {
        page_->save_screenshot(kArtefacts / (name_ + "-failed.png"), 10s);
        for (const std::string& e : page_->take_page_errors()) std::cerr << "page: " << e << "\n";
        std::cerr << "page status: "
                  << page_->evaluate("JSON.stringify(window.ioctView?.status)", 5s) << "\n";
      } catch (const std::exception& e) {
        std::cerr << "no failure screenshot: " << e.what() << "\n";
      }
    }
    if (appliance_) {
      appliance_->keep_folder();
      std::cerr << "the processes' logs are in " << appliance_->folder() << "\n"
                << appliance_->logs();
    }
  }

  virtual ApplianceOptions appliance_options() const {
    ApplianceOptions options;
    options.tag = "page";
    return options;
  }

  void open(const std::string& url) { page_ = browser_->open_page(url, 20s); }

  // Waits for `condition` (JavaScript) and fails with the page's status when it does not hold.
  nlohmann::json expect_within(const std::string& condition, std::chrono::milliseconds timeout) {
    nlohmann::json last;
    std::optional<nlohmann::json> value = page_->wait_until(condition, timeout, &last);
    EXPECT_TRUE(value.has_value())
        << "not within " << timeout.count() << " ms: " << condition
        << "\n  page status: " << page_->evaluate("JSON.stringify(window.ioctView?.status)", 5s);
    return value.value_or(nlohmann::json());
  }

  std::string name_;
  std::unique_ptr<LiveAppliance> appliance_;
  std::unique_ptr<HeadlessChromium> browser_;
  std::unique_ptr<BrowserPage> page_;
};

TEST_F(LiveViewPage, SurgeonsDisplayShowsLiveFramesThatChangeAndItsScreenshotIsKept) {
  open(appliance_->url("/"));
  ASSERT_FALSE(expect_within(live_with_frames(1), 30s).is_null());
  // The first frames of a run may show a volume whose B-scans have not all arrived (black where
  // they are missing): the picture must show something within the bound.
  page_->wait_until("(" + std::string(kRenderPixels) + ").mean > 2.0", 30s);
  const nlohmann::json first = page_->evaluate(kRenderPixels, 5s);
  EXPECT_GT(first.at("mean").get<double>(), 2.0) << "the render shows something, not black";

  // The volume auto-rotates and new groups arrive: later frames differ, pixel for pixel.
  const std::string later = "ioctView.status.lastFrame.frame >= " +
                            std::to_string(first.at("frame").get<long long>() + 3);
  ASSERT_FALSE(expect_within(later, 30s).is_null());
  const nlohmann::json second = page_->evaluate(kRenderPixels, 5s);
  EXPECT_NE(first.at("hash"), second.at("hash")) << "frames arrive but the picture never changes";

  // The B-scan beside it, and its position marked on the volume.
  EXPECT_EQ(page_->evaluate("document.getElementById('bscan-locator-label').textContent", 5s)
                .get<std::string>()
                .rfind("B-scan ", 0),
            0u);
  const nlohmann::json state_line =
      page_->evaluate("document.getElementById('state-line').textContent", 5s);
  EXPECT_NE(state_line.get<std::string>().find("groups/s"), std::string::npos) << state_line;

  const std::filesystem::path shot = kArtefacts / "surgeons-display-live.png";
  page_->save_screenshot(shot, 10s);
  EXPECT_GT(std::filesystem::file_size(shot), 10'000u) << shot;
  EXPECT_TRUE(page_->take_page_errors().empty());
}

TEST_F(LiveViewPage, ThresholdAndModeControlsChangeTheNextFramesPixels) {
  open(appliance_->operator_url("/control"));
  ASSERT_FALSE(expect_within(live_with_frames(1) + " && ioctView.status.role === 'operator'", 30s)
                   .is_null());
  // Hold the camera still, so only the controls change the picture.
  page_->evaluate(
      "(() => { const e = document.getElementById('ctl-view-auto_rotate'); if (e.checked) "
      "e.click(); })()",
      5s);
  // On the CPU path a moving view is rendered small and sharpened once it stands still: compare
  // full-size frames only.
  ASSERT_FALSE(expect_within("ioctView.status.lastState.params.view.auto_rotate === false && "
                             "ioctView.status.lastFrame.generation >= "
                             "ioctView.status.lastState.generation && "
                             "ioctView.status.lastFrame.width === 320",
                             20s)
                   .is_null());
  const nlohmann::json before = page_->evaluate(kRenderPixels, 5s);

  // Threshold 0.35 -> 0.9: most of the retina falls below it and the render goes dark.
  page_->evaluate(
      "(() => { const e = document.getElementById('ctl-enhanced-threshold'); e.value = 0.9; "
      "e.dispatchEvent(new Event('input')); })()",
      5s);
  const std::string newer = "ioctView.status.lastFrame.generation > " +
                            std::to_string(before.at("generation").get<long long>()) +
                            " && ioctView.status.lastFrame.width === 320";
  ASSERT_FALSE(expect_within(newer, 20s).is_null());
  const nlohmann::json thresholded = page_->evaluate(kRenderPixels, 5s);
  EXPECT_LT(thresholded.at("mean").get<double>(), before.at("mean").get<double>() * 0.8)
      << "threshold 0.9 should darken the render; before " << before << ", after " << thresholded;
  EXPECT_EQ(page_->evaluate("ioctView.status.lastState.params.enhanced.threshold", 5s), 0.9);

  // Render mode -> la-mip: the next frames say so and look different.
  page_->evaluate(
      "(() => { const e = document.getElementById('ctl-mode'); e.value = 'la-mip'; "
      "e.dispatchEvent(new Event('change')); })()",
      5s);
  ASSERT_FALSE(expect_within("ioctView.status.lastFrame.mode === 'la-mip'", 20s).is_null());
  const nlohmann::json la_mip = page_->evaluate(kRenderPixels, 5s);
  EXPECT_NE(la_mip.at("hash"), thresholded.at("hash"));

  // A value the server refuses: its error text appears beside the control that sent it.
  page_->evaluate("ioctControl.sender.change('enhanced.kg1', -1)", 5s);
  const nlohmann::json error = expect_within(
      "document.querySelector('[data-path=\"enhanced.kg1\"] .control-error').textContent", 10s);
  EXPECT_NE(error.dump().find("kg1"), std::string::npos) << error;

  page_->save_screenshot(kArtefacts / "control-page-la-mip.png", 10s);

  // Enter in a field submits the form: the page stays (a reload would drop the token with the
  // fragment, and the operator's role with it).
  page_->evaluate(
      "window.ioctStillThisPage = true; document.getElementById('controls').requestSubmit(); true",
      5s);
  std::this_thread::sleep_for(1s);  // a reload of a page served locally starts well within it
  EXPECT_EQ(page_->evaluate("window.ioctStillThisPage === true && "
                            "ioctView.status.role === 'operator'",
                            5s),
            true);
}

TEST_F(LiveViewPage, StereoPairFillsTheSurgeonsDisplaySideBySide) {
  open(appliance_->operator_url("/control"));
  ASSERT_FALSE(expect_within(live_with_frames(1) + " && ioctView.status.role === 'operator'", 30s)
                   .is_null());
  page_->evaluate("document.getElementById('ctl-view-stereo').click()", 5s);
  ASSERT_FALSE(expect_within("ioctView.status.lastFrame.stereo === true", 20s).is_null());

  // The surgeon's display, in a browser window of its own: the left | right pair at the
  // display's full size, nothing beside it.
  auto display = browser_->open_page(appliance_->url("/"), 20s);
  nlohmann::json layout;
  ASSERT_TRUE(display
                  ->wait_until(R"((() => {
    const s = window.ioctView && ioctView.status;
    if (!s || !s.lastFrame || !s.lastFrame.stereo || !s.lastState ||
        s.lastState.signal !== 'live') return null;
    const box = document.getElementById('render').getBoundingClientRect();
    return { stereo: document.body.classList.contains('stereo'), width: box.width,
             height: box.height, windowWidth: innerWidth, frameWidth: s.lastFrame.width,
             frameHeight: s.lastFrame.height,
             bscanShown: getComputedStyle(document.getElementById('bscan-panel')).display };
  })())",
                               30s, &layout)
                  .has_value())
      << layout;
  EXPECT_TRUE(layout.at("stereo").get<bool>());
  EXPECT_EQ(layout.at("width"), layout.at("windowWidth")) << "the pair spans the display";
  EXPECT_EQ(layout.at("bscanShown"), "none");
  // Each eye keeps the render's aspect (the CPU path renders a moving view smaller).
  EXPECT_NEAR(layout.at("frameWidth").get<double>() / layout.at("frameHeight").get<double>(),
              2.0 * 320 / 240, 0.05)
      << "left and right side by side";
  display->save_screenshot(kArtefacts / "surgeons-display-stereo.png", 10s);
}

TEST_F(LiveViewPage, StaleBannerAppearsWhenScanningStopsAndGoesWhenItResumes) {
  open(appliance_->url("/"));
  ASSERT_FALSE(expect_within(live_with_frames(2), 30s).is_null());

  appliance_->rt_command("stop");
  const auto stopped = Clock::now();
  // --stale-after 1 s, a state message every 0.25 s and at every change, the page's check every
  // 0.1 s: the banner must be up within 2 s of the stop (the bound plus the last group's period
  // and the messages' way, with room for a loaded machine).
  const std::string banner_up =
      "ioctView.status.signal !== 'live' && !document.getElementById('signal-banner').hidden && "
      "document.getElementById('picture').classList.contains('not-live') && "
      "document.getElementById('signal-banner-title').textContent";
  const nlohmann::json title = expect_within(banner_up, 2500ms);
  const auto shown_after =
      std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - stopped);
  std::printf("[ stats    ] banner %s after %lld ms\n", title.dump().c_str(),
              static_cast<long long>(shown_after.count()));
  EXPECT_EQ(title, "STALE") << "the pipeline runs, the scan stopped: stale, not no signal";
  EXPECT_NE(page_->evaluate("document.getElementById('signal-banner-detail').textContent", 5s)
                .get<std::string>()
                .find(" old"),
            std::string::npos)
      << "the banner gives the age";
  page_->save_screenshot(kArtefacts / "surgeons-display-stale.png", 10s);

  appliance_->rt_command("start");
  EXPECT_FALSE(expect_within(live_with_frames(1), 15s).is_null())
      << "the banner goes once groups arrive again";
}

TEST_F(LiveViewPage, ViewerWithoutTheTokenCannotChangeAnything) {
  nlohmann::json params_before = nlohmann::json::parse(appliance_->http("GET", "/api/params").body);
  open(appliance_->url("/control"));  // no #token=
  ASSERT_FALSE(
      expect_within(live_with_frames(1) + " && ioctView.status.role === 'viewer'", 30s).is_null());
  EXPECT_NE(page_->evaluate("document.getElementById('role').textContent", 5s)
                .get<std::string>()
                .find("Viewer"),
            std::string::npos);

  // Over the WebSocket: parameters, scan and snapshot are all refused.
  for (const char* request : {"{type: 'params', changes: {enhanced: {threshold: 0.9}}}",
                              "{type: 'scan', cmd: 'stop'}", "{type: 'snapshot'}"}) {
    const nlohmann::json reply =
        page_->evaluate(std::string("ioctView.socket.request(") + request + ")", 10s);
    EXPECT_EQ(reply.value("ok", true), false) << request << " -> " << reply;
  }
  // Over HTTP from the page, without a bearer token: 401.
  const nlohmann::json status = page_->evaluate(
      "fetch('/api/params', {method: 'POST', headers: {'Content-Type': 'application/json'}, "
      "body: JSON.stringify({enhanced: {threshold: 0.9}})}).then(r => r.status)",
      10s);
  EXPECT_EQ(status, 401);
  // Through the page's own control: the refusal shows beside it.
  page_->evaluate(
      "(() => { const e = document.getElementById('ctl-enhanced-threshold'); e.value = 0.9; "
      "e.dispatchEvent(new Event('input')); })()",
      5s);
  EXPECT_FALSE(expect_within("document.querySelector('[data-path=\"enhanced.threshold\"] "
                             ".control-error').textContent",
                             10s)
                   .is_null());

  nlohmann::json params_after = nlohmann::json::parse(appliance_->http("GET", "/api/params").body);
  EXPECT_EQ(params_after.at("generation"), params_before.at("generation")) << "nothing changed";
  // The auto-rotation turns the camera meanwhile; every other parameter is as it was.
  params_after["params"]["view"].erase("azimuth_deg");
  params_before["params"]["view"].erase("azimuth_deg");
  EXPECT_EQ(params_after.at("params"), params_before.at("params")) << "nothing changed";
  // The server's verdict: the scan still runs (the page's own picture may lag on a loaded machine).
  // Only a state sent after the refusals counts: the one held from before is dropped first.
  page_->evaluate("ioctView.status.lastState = null", 5s);
  EXPECT_TRUE(page_
                  ->wait_until("ioctView.status.lastState && "
                               "ioctView.status.lastState.signal === 'live'",
                               10s)
                  .has_value())
      << "still scanning";
}

TEST_F(LiveViewPage, AViewerWhoDragsThePictureOrbitsItsOwnViewAndCanFollowAgain) {
  const nlohmann::json before = nlohmann::json::parse(appliance_->http("GET", "/api/params").body);
  open(appliance_->url("/control"));  // no #token=: a viewer
  ASSERT_FALSE(
      expect_within(live_with_frames(1) + " && ioctView.status.role === 'viewer'", 30s).is_null());
  page_->evaluate(
      "(() => { const c = document.getElementById('render'); const r = c.getBoundingClientRect();"
      " const at = (x, y) => ({pointerId: 7, clientX: r.x + x, clientY: r.y + y, bubbles: true});"
      " c.dispatchEvent(new PointerEvent('pointerdown', at(100, 100)));"
      " c.dispatchEvent(new PointerEvent('pointermove', at(220, 130)));"
      " c.dispatchEvent(new PointerEvent('pointerup', at(220, 130))); })()",
      5s);
  ASSERT_FALSE(expect_within("ioctView.status.lastFrame && ioctView.status.lastFrame.view > 0 && "
                             "!document.getElementById('follow').hidden",
                             30s)
                   .is_null())
      << "the viewer's frames come from a camera of its own";
  // The shared view is untouched (its auto-rotation turns it meanwhile; the generation counts the
  // changes of every view, this viewer's own included).
  nlohmann::json shared_before = before.at("params");
  nlohmann::json shared_after =
      nlohmann::json::parse(appliance_->http("GET", "/api/params").body).at("params");
  shared_before["view"].erase("azimuth_deg");
  shared_after["view"].erase("azimuth_deg");
  EXPECT_EQ(shared_after, shared_before) << "the shared view is untouched";

  page_->evaluate("document.getElementById('follow').click()", 5s);
  EXPECT_FALSE(
      expect_within("ioctView.status.lastFrame && ioctView.status.lastFrame.view === 0", 30s)
          .is_null())
      << "back on the shared view";
}

}  // namespace
// Forceps above the retina, in the middle of the field (so the B-scan shown, the middle one,
// passes through the tip), and ioct-gpu finding them.
class LiveViewPageWithForceps : public LiveViewPage {
 protected:
  ApplianceOptions appliance_options() const override {
    ApplianceOptions options;
    options.tag = "tip";
    options.instruments = {"forceps:x=0.1,y=0,depth=0.3,yaw=180,pitch=20"};
    return options;
  }
};

TEST_F(LiveViewPageWithForceps, TipDistancesAreShownOverTheRenderAndTheTipMarkedOnTheBscan) {
  open(appliance_->url("/"));
  const std::string found =
      live_with_frames(1) + " && ioctView.status.lastFrame.instrument?.state === 'found'";
  ASSERT_FALSE(expect_within(found, 60s).is_null());
  const nlohmann::json shown = page_->evaluate(R"((() => {
    const e = document.getElementById('instrument-readout');
    return { hidden: e.hidden, kind: e.className, text: e.textContent,
             instrument: ioctView.status.lastFrame.instrument,
             bscan: ioctView.status.lastFrame.bscan_index,
             marked: ioctView.status.tipMarked,
             onRender: ioctView.status.tipOnRender,
             tipBscansBytes: ioctView.status.lastFrame.tip_bscans_bytes,
             tipBscansShown: !document.getElementById('tip-bscans').hidden,
             tipBscansWidth: document.getElementById('tip-bscans').width };
  })())",
                                               5s);
  const nlohmann::json& tip = shown.at("instrument");
  EXPECT_FALSE(shown.at("hidden").get<bool>()) << shown;
  // The forceps hang above the retina: both distances measured or inferred, the RPE farther
  // below the tip than the ILM, and the page shows the RPE's as the frame carries it.
  ASSERT_TRUE(tip.at("to_rpe_um").is_number()) << shown;
  ASSERT_TRUE(tip.at("to_ilm_um").is_number()) << shown;
  EXPECT_GT(tip.at("to_ilm_um").get<double>(), 0.0) << shown;
  EXPECT_GT(tip.at("to_rpe_um").get<double>(), tip.at("to_ilm_um").get<double>()) << shown;
  const std::string text = shown.at("text").get<std::string>();
  const long rpe = std::lround(std::abs(tip.at("to_rpe_um").get<double>()));
  EXPECT_NE(text.find("RPE"), std::string::npos) << text;
  EXPECT_NE(text.find(std::to_string(rpe) + " µm"), std::string::npos) << text << " vs " << tip;
  const std::string kind = shown.at("kind").get<std::string>();
  EXPECT_TRUE(kind == "measured" || kind == "inferred") << kind;
  // The tip lies in the field's middle: on or next to the B-scan shown, which marks it.
  const double tip_bscan = tip.at("tip_voxel").at(0).get<double>();
  EXPECT_NEAR(tip_bscan, shown.at("bscan").get<double>(), 1.5) << shown;
  EXPECT_TRUE(shown.at("marked").get<bool>()) << shown;
  // ... and over the render (enhanced, auto-rotating): ioct-gpu placed it in the picture.
  EXPECT_TRUE(shown.at("onRender").get<bool>()) << shown;
  // The B-scan pair through the tip (along | across the forceps) comes with the frame and shows.
  EXPECT_GT(shown.at("tipBscansBytes").get<int>(), 1000) << shown;
  EXPECT_TRUE(shown.at("tipBscansShown").get<bool>()) << shown;

  // /metrics serves the same tip (the newest shared frame's; found, and its RPE distance).
  const HttpReply metrics = appliance_->http("GET", "/metrics");
  EXPECT_EQ(metrics.status, 200);
  EXPECT_NE(metrics.body.find("\nioct_instrument_found 1\n"), std::string::npos) << metrics.body;
  EXPECT_NE(metrics.body.find("\nioct_instrument_tip_to_rpe_meters "), std::string::npos);

  const std::filesystem::path shot = kArtefacts / "surgeons-display-instrument.png";
  page_->save_screenshot(shot, 10s);
  EXPECT_GT(std::filesystem::file_size(shot), 10'000u) << shot;

  // A stopped scan: the last distance is greyed with the picture, never shown as live.
  appliance_->rt_command("stop");
  const std::string greyed =
      "document.getElementById('picture').classList.contains('not-live') && "
      "getComputedStyle(document.getElementById('instrument-readout')).filter";
  const nlohmann::json filter = expect_within(greyed, 5s);
  EXPECT_NE(filter.dump().find("grayscale"), std::string::npos) << filter;
  EXPECT_TRUE(page_->take_page_errors().empty());
}

}  // namespace ioct::view_test
