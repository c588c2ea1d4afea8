// The pages' ES modules on their own, in the browser, without a server: the frame message is
// parsed as the protocol lays it out, the signal is never live without a live, recent, connected
// server, the state line reads ioct-rt's status, parameter changes are throttled and merged, the
// socket hands events to their handlers, and a picture that comes again unchanged is not decoded
// again.
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "ioct/devtools/headless_chromium.hpp"

namespace ioct::devtools {
namespace {

using namespace std::chrono_literals;

const std::string kModules = std::string("file://") + IOCT_VIEW_WWW_DIR + "/js/";

class PageModules : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(HeadlessChromium::find_executable().has_value())
        << "no Chromium: install the Debian package chromium (tools/setup.sh does)";
    ChromiumOptions options;
    options.window_width = 320;
    options.window_height = 240;
    options.allow_file_access = true;
    browser_ = std::make_unique<HeadlessChromium>(options);
    page_ = browser_->open_page(std::string("file://") + IOCT_VIEW_WWW_DIR + "/index.html");
  }

  // Runs `body` (an async function's body) with module `name` imported as `m`.
  nlohmann::json with_module(const std::string& name, const std::string& body) {
    return page_->evaluate(
        "(async () => { const m = await import('" + kModules + name + "'); " + body + " })()", 10s);
  }

  std::unique_ptr<HeadlessChromium> browser_;
  std::unique_ptr<BrowserPage> page_;
};

TEST_F(PageModules, FrameMessageIsParsedAsTheProtocolLaysItOut) {
  const nlohmann::json parsed = with_module("frame-message.js", R"(
    const meta = new TextEncoder().encode(JSON.stringify(
        {type: 'frame', frame: 7, render_bytes: 3, bscan_bytes: 2}));
    const bytes = new Uint8Array(4 + meta.length + 5);
    new DataView(bytes.buffer).setUint32(0, meta.length, true);
    bytes.set(meta, 4);
    bytes.set([1, 2, 3, 9, 8], 4 + meta.length);
    const f = m.parseFrameMessage(bytes.buffer);
    let truncated = '';
    try { m.parseFrameMessage(bytes.buffer.slice(0, bytes.length - 1)); }
    catch (e) { truncated = e.message; }
    return {frame: f.meta.frame, render: [...f.render], bscan: [...f.bscan], truncated};)");
  EXPECT_EQ(parsed.at("frame"), 7);
  EXPECT_EQ(parsed.at("render"), (nlohmann::json{1, 2, 3}));
  EXPECT_EQ(parsed.at("bscan"), (nlohmann::json{9, 8}));
  EXPECT_NE(parsed.at("truncated").get<std::string>().find("past the end"), std::string::npos);
}

// A frame marked pictures_repeated carries the render alone: it gets the B-scan and the tip's pair
// of the last frame that carried them, sizes included, if they are the pictures it names; one
// before any such frame, naming others, or after an unreadable frame is an error.
TEST_F(PageModules, ARepeatedFrameGetsTheLastPicturesReceived) {
  const nlohmann::json r = with_module("frame-message.js", R"(
    const message = (meta, payload) => {
      const json = new TextEncoder().encode(JSON.stringify(Object.assign({type: 'frame'}, meta)));
      const bytes = new Uint8Array(4 + json.length + payload.length);
      new DataView(bytes.buffer).setUint32(0, json.length, true);
      bytes.set(json, 4);
      bytes.set(payload, 4 + json.length);
      return m.parseFrameMessage(bytes.buffer);
    };
    const pictures = new m.FramePictures();
    const refusal = (meta, payload) => {
      try { pictures.complete(message(meta, payload)); } catch (e) { return e.message; }
      return '';
    };
    const repeated = {render_bytes: 1, bscan_bytes: 0, tip_bscans_bytes: 0,
                      pictures_repeated: true};
    const early = refusal(Object.assign({frame: 1, pictures: 4}, repeated), [5]);
    pictures.complete(message({frame: 2, pictures: 4, render_bytes: 1, bscan_bytes: 2,
                               tip_bscans_bytes: 1}, [5, 8, 9, 4]));
    const f = pictures.complete(message({frame: 3, pictures: 4, render_bytes: 2, bscan_bytes: 0,
                                         tip_bscans_bytes: 0, pictures_repeated: true}, [6, 6]));
    // Pictures it never received (a frame lost or unreadable before it): refused, not the old.
    const other = refusal(Object.assign({frame: 4, pictures: 5}, repeated), [7]);
    pictures.forget();
    const forgotten = refusal(Object.assign({frame: 5, pictures: 4}, repeated), [7]);
    return {early, other, forgotten, render: [...f.render], bscan: [...f.bscan],
            tip: [...f.tipBscans], sizes: [f.meta.bscan_bytes, f.meta.tip_bscans_bytes]};)");
  for (const char* refused : {"early", "other", "forgotten"}) {
    EXPECT_NE(r.at(refused).get<std::string>().find("never received"), std::string::npos)
        << refused << ": " << r;
  }
  EXPECT_EQ(r.at("render"), (nlohmann::json{6, 6}));
  EXPECT_EQ(r.at("bscan"), (nlohmann::json{8, 9}));
  EXPECT_EQ(r.at("tip"), (nlohmann::json{4}));
  EXPECT_EQ(r.at("sizes"), (nlohmann::json{2, 1}));
}

TEST_F(PageModules, InstrumentReadoutTellsMeasuredInferredNoneAndWarningApart) {
  const nlohmann::json r = with_module("instrument-readout.js", R"(
    const tip = (extra) => Object.assign({state: 'found', instruments: 1, tip_voxel: [10, 64, 80],
        tip_um: [1000, 500, 300], to_ilm_um: 84.6, to_rpe_um: 301.2, distance: 'measured',
        translucent: false, warning: false, warn_rpe_um: 100}, extra);
    const out = {};
    out.off = m.describeInstrument({state: 'off'});
    out.missing = m.describeInstrument(undefined);
    out.none = m.describeInstrument({state: 'none'});
    out.measured = m.describeInstrument(tip({}));
    out.below = m.describeInstrument(tip({to_ilm_um: -35.4}));
    out.inferred = m.describeInstrument(tip({distance: 'inferred'}));
    out.unsegmented = m.describeInstrument(tip({distance: 'none', to_ilm_um: null, to_rpe_um: null}));
    out.warning = m.describeInstrument(tip({to_rpe_um: 60, warning: true}));
    // The marker: drawn on the B-scan through the tip, not on one 5 B-scans away; red pixels
    // where the warning ring passes (right of the tip by its radius).
    const canvas = document.createElement('canvas');
    canvas.width = 128; canvas.height = 256;
    const meta = {bscan_index: 10, bscans: 32, bscan_width: 128, bscan_height: 256,
                  instrument: tip({warning: true})};
    out.drawnHere = m.drawTipMarker(canvas, meta);
    const r = Math.max(8, canvas.width / 40);
    const px = canvas.getContext('2d').getImageData(Math.round(64.5 + r), 80, 1, 1).data;
    out.ringPixel = [px[0], px[1], px[2], px[3]];
    out.drawnElsewhere = m.drawTipMarker(canvas, Object.assign({}, meta, {bscan_index: 15}));
    out.locator = m.tipOnLocator(meta);
    out.locatorOff = m.tipOnLocator({bscans: 32, bscan_width: 128, instrument: {state: 'none'}});
    return out;)");
  EXPECT_FALSE(r.at("off").at("shown").get<bool>());
  EXPECT_FALSE(r.at("missing").at("shown").get<bool>());
  EXPECT_EQ(r.at("none").at("kind"), "none");
  EXPECT_EQ(r.at("none").at("title"), "No instrument");
  EXPECT_EQ(r.at("measured").at("kind"), "measured");
  EXPECT_EQ(r.at("measured").at("lines"), (nlohmann::json{"RPE 301 µm above", "ILM 85 µm above"}));
  EXPECT_EQ(r.at("below").at("lines").at(1), "ILM 35 µm below");
  EXPECT_EQ(r.at("inferred").at("kind"), "inferred");
  EXPECT_EQ(r.at("inferred").at("lines").at(0), "RPE ≈ 301 µm above");
  EXPECT_EQ(r.at("unsegmented").at("kind"), "unknown");
  EXPECT_EQ(r.at("warning").at("kind"), "warning");
  EXPECT_EQ(r.at("warning").at("title"), "TIP WITHIN 100 µm OF THE RPE");
  EXPECT_TRUE(r.at("drawnHere").get<bool>());
  const nlohmann::json& ring = r.at("ringPixel");
  EXPECT_GT(ring.at(0).get<int>(), 200) << ring;  // the warning's red
  EXPECT_LT(ring.at(1).get<int>(), 150) << ring;
  EXPECT_GT(ring.at(3).get<int>(), 50) << ring;  // drawn (antialiased at its edge)
  EXPECT_FALSE(r.at("drawnElsewhere").get<bool>());
  EXPECT_NEAR(r.at("locator").at("x").get<double>(), 64.5 / 128, 1e-9);
  EXPECT_NEAR(r.at("locator").at("y").get<double>(), 10.5 / 32, 1e-9);
  EXPECT_TRUE(r.at("locatorOff").is_null());
}

TEST_F(PageModules, SignalIsLiveOnlyWhileTheServerSaysSoRecentlyOverAnOpenConnection) {
  const nlohmann::json r = with_module("signal-watch.js", R"(
    let now = 0;
    const w = new m.SignalWatch(() => now);
    const at = () => w.current().signal;
    const out = {};
    out.before = at();
    w.connection(true);
    out.connectedNoState = at();
    w.state({signal: 'live', age_ms: 40});
    out.live = at();
    now = 900; out.quiet900 = at();
    now = 1100; out.silent1100 = at();
    w.frame(); out.frameAgain = at();
    w.state({signal: 'stale', age_ms: 2000}); now = 1600;
    out.stale = at(); out.staleAge = w.current().ageMs;
    w.state({signal: 'no_signal'}); out.noSignal = at();
    w.state({signal: 'live', age_ms: 10}); w.connection(false); out.closed = at();
    out.formatted = [m.formatAge(3200), m.formatAge(65000), m.formatAge(null)];
    return out;)");
  EXPECT_EQ(r.at("before"), "no_signal");
  EXPECT_EQ(r.at("connectedNoState"), "no_signal");
  EXPECT_EQ(r.at("live"), "live");
  EXPECT_EQ(r.at("quiet900"), "live");
  EXPECT_EQ(r.at("silent1100"), "no_signal") << "1 s without a message is not live";
  EXPECT_EQ(r.at("frameAgain"), "live");
  EXPECT_EQ(r.at("stale"), "stale");
  EXPECT_DOUBLE_EQ(r.at("staleAge").get<double>(), 2500.0) << "the age keeps growing locally";
  EXPECT_EQ(r.at("noSignal"), "no_signal");
  EXPECT_EQ(r.at("closed"), "no_signal") << "a closed WebSocket is never live";
  EXPECT_EQ(r.at("formatted"), (nlohmann::json{"3.2 s", "1 min 05 s", ""}));
}

// The server says live, messages keep coming, but the picture drawn is older than the server's
// stale bound (a renderer slower than the scanner, a render stream that stopped): STALE, with the
// picture's own age; a recent picture is live again.
TEST_F(PageModules, APictureOlderThanTheStaleBoundIsStaleWhileTheServerSaysLive) {
  const nlohmann::json r = with_module("signal-watch.js", R"(
    let now = 0;
    const w = new m.SignalWatch(() => now);
    const at = () => w.current();
    const out = {};
    w.connection(true);
    w.state({signal: 'live', age_ms: 40, stale_after_ms: 300});
    out.noPictureYet = at().signal;
    w.pictureDrawn(120);
    out.recent = at().signal;
    now = 150; w.state({signal: 'live', age_ms: 30, stale_after_ms: 300});
    out.atTheBound = at().signal;
    now = 200; w.frame();
    out.behind = at();
    w.pictureDrawn(20);
    out.caughtUp = at().signal;
    w.pictureDrawn(20, 100);  // received at 100, drawn at 200: 20 + 100 ms old
    out.receivedEarlier = w.pictureAge();
    w.pictureDrawn(5000);
    out.slowRenderer = at();
    w.state({signal: 'stale', age_ms: 900, stale_after_ms: 300});
    out.serverStale = at();
    w.pictureDrawn(undefined);
    w.state({signal: 'live', age_ms: 10, stale_after_ms: 300});
    out.noAge = at().signal;
    return out;)");
  EXPECT_EQ(r.at("noPictureYet"), "live") << "nothing drawn: nothing shown as live";
  EXPECT_EQ(r.at("recent"), "live");
  EXPECT_EQ(r.at("atTheBound"), "live") << "120 + 150 ms is within 300 ms";
  EXPECT_EQ(r.at("behind").at("signal"), "stale") << "120 + 200 ms is past 300 ms";
  EXPECT_DOUBLE_EQ(r.at("behind").at("ageMs").get<double>(), 320.0) << "the picture's own age";
  EXPECT_NE(r.at("behind").at("reason").get<std::string>().find("picture lags the scan"),
            std::string::npos);
  EXPECT_EQ(r.at("caughtUp"), "live");
  EXPECT_DOUBLE_EQ(r.at("receivedEarlier").get<double>(), 120.0) << "the age counts from arrival";
  EXPECT_EQ(r.at("slowRenderer").at("signal"), "stale");
  EXPECT_EQ(r.at("serverStale").at("signal"), "stale");
  EXPECT_DOUBLE_EQ(r.at("serverStale").at("ageMs").get<double>(), 900.0)
      << "the server's verdict and age first";
  EXPECT_EQ(r.at("noAge"), "live") << "a frame without an age is not judged by it";
}

TEST_F(PageModules, StateLineReadsTheScannersStatus) {
  const nlohmann::json r = with_module("state-line.js", R"(
    const d = (rt) => m.describeState({groups_per_s: 20.04, dropped: 3, rt});
    return {
      scanning: d({safety: {state: 'scanning', emission_readback: true}}),
      fault: d({status: {safety: {state: 'fault', faults: 'k_clock', emission_readback: false}}}),
      idle: d({safety: {state: 'idle', emission_readback: false}}),
      replayEnded: d({safety: {state: 'fault', faults: 'digitizer_lost', emission_readback: false},
                      acquisition: {replay: true, replay_error: 'run.h5: group 3 at byte 9: bad'}}),
      replaying: d({safety: {state: 'scanning', emission_readback: true},
                    acquisition: {replay: true, replay_error: ''}}),
      rearming: d({safety: {state: 'arming', emission_readback: false},
                   acquisition: {replay: true, replay_error: 'run.h5: group 3 at byte 9: bad'}}),
      unknown: m.describeState({rt: null, rt_error: 'ioct-rt not reachable'}),
      recent: m.describeState({rt_age_ms: 900, rt: {safety: {state: 'scanning',
                                                              emission_readback: true}}}),
      old: m.describeState({rt_age_ms: 2500, rt: {safety: {state: 'scanning',
                                                           emission_readback: true}}}),
    };)");
  EXPECT_EQ(r.at("recent").at("laser"), "LASER ON");
  EXPECT_EQ(r.at("old").at("scan"), "scanner: its last status is 2.5 s old");
  EXPECT_EQ(r.at("old").at("scanClass"), "unknown");
  EXPECT_EQ(r.at("old").at("laser"), "laser ?") << "an old status is not the laser's state now";
  EXPECT_FALSE(r.at("old").at("laserOn").get<bool>());
  EXPECT_EQ(r.at("scanning").at("scan"), "SCANNING");
  EXPECT_EQ(r.at("scanning").at("laser"), "LASER ON");
  EXPECT_EQ(r.at("scanning").at("rate"), "20.0 groups/s");
  EXPECT_EQ(r.at("scanning").at("drops"), "3 dropped");
  EXPECT_EQ(r.at("fault").at("scan"), "FAULT: k_clock");
  EXPECT_EQ(r.at("fault").at("laser"), "laser off");
  EXPECT_EQ(r.at("idle").at("scan"), "STOPPED");
  EXPECT_EQ(r.at("replayEnded").at("scan"),
            "FAULT: digitizer_lost — the replay stopped: run.h5: group 3 at byte 9: bad");
  EXPECT_EQ(r.at("replaying").at("scan"), "SCANNING");
  EXPECT_EQ(r.at("rearming").at("scan"), "ARMING") << "the last arming's reason is not this one's";
  EXPECT_EQ(r.at("unknown").at("scan"), "scanner: ioct-rt not reachable");
}

TEST_F(PageModules, ParameterChangesGoOutAtMostEvery30MsMergedAndInOrder) {
  const nlohmann::json r = with_module("param-sender.js", R"(
    const sent = [];
    const replies = [];
    // Each message at the time the sender decided to send it (its lastSentAt): the moment the
    // mock is handed the message can come later by however long the machine keeps the page's
    // thread waiting, which is not the sender's doing.
    let s = null;
    const socket = {request: async (msg) => { sent.push({at: s.lastSentAt, msg});
                                              return {ok: true}; }};
    s = new m.ParamSender(socket, {intervalMs: 30,
                                   onReply: (reply, paths) => replies.push(paths)});
    const start = performance.now();
    // A dragged slider: 50 changes over ~250 ms, with a second control changed once.
    for (let i = 0; i < 50; ++i) {
      s.change('enhanced.threshold', i / 100);
      if (i === 10) s.change('view.zoom', 2);
      await new Promise((r) => setTimeout(r, 5));
    }
    await new Promise((r) => setTimeout(r, 100));
    const gaps = sent.slice(1).map((x, i) => x.at - sent[i].at);
    return {count: sent.length, minGap: Math.min(...gaps),
            last: sent[sent.length - 1].msg, zoomSent: sent.some((x) => x.msg.changes.view?.zoom === 2),
            type: sent[0].msg.type, replies: replies.length};)");
  EXPECT_GE(r.at("count").get<int>(), 4);
  EXPECT_LE(r.at("count").get<int>(), 15) << "50 changes in ~250 ms: at most one per 30 ms";
  EXPECT_GE(r.at("minGap").get<double>(), 29.99)
      << "by the page's own clock, between the sender's decisions to send";
  EXPECT_EQ(r.at("type"), "params");
  EXPECT_EQ(r.at("last").at("changes").at("enhanced").at("threshold"), 0.49)
      << "the last value always goes out";
  EXPECT_EQ(r.at("zoomSent"), true) << "a change merged into a message is not lost";
  EXPECT_EQ(r.at("replies"), r.at("count"));
}

// The socket hands each text message to its own handler: the footswitch's action, and the news
// that a viewer's own view was closed with its reason; a malformed one is a problem, not a throw.
TEST_F(PageModules, TheSocketHandsEventsToTheirHandlers) {
  const nlohmann::json r = with_module("live-socket.js", R"(
    const seen = [];
    const socket = new m.LiveSocket({
      onFootswitch: (action) => seen.push(['footswitch', action]),
      onOwnViewClosed: (reason) => seen.push(['closed', reason]),
      onProblem: (problem) => seen.push(['problem', problem.slice(0, 22)])});
    socket.receive(JSON.stringify({type: 'footswitch', action: 'toggle-bscan'}));
    socket.receive(JSON.stringify({type: 'own_view_closed', reason: 'ioct-gpu restarted'}));
    socket.receive('{not json');
    return seen;)");
  using J = nlohmann::json;
  EXPECT_EQ(r, J::array({J::array({"footswitch", "toggle-bscan"}),
                         J::array({"closed", "ioct-gpu restarted"}),
                         J::array({"problem", "bad message from the s"})}));
}

TEST_F(PageModules, TokenComesFromTheFragmentAndGoesOutAsABearerHeader) {
  const nlohmann::json r = with_module("token.js", R"(
    return {token: m.tokenFromFragment('#token=abc123&x=1'), none: m.tokenFromFragment(''),
            header: m.authHeaders('abc123'), noHeader: m.authHeaders('')};)");
  EXPECT_EQ(r.at("token"), "abc123");
  EXPECT_EQ(r.at("none"), "");
  EXPECT_EQ(r.at("header").at("Authorization"), "Bearer abc123");
  EXPECT_TRUE(r.at("noHeader").empty());
}

// The B-scan beside the render comes again in most frames unchanged: decoded once while its
// bytes stay the same (even in another message's buffer), again when they change, and the bitmap
// it replaces closed; a real JPEG decodes to its size, once.
TEST_F(PageModules, ARepeatedPictureIsDecodedOnlyWhenItsBytesChange) {
  const nlohmann::json r = with_module("repeated-picture.js", R"(
    const decoded = [], closed = [];
    const picture = new m.RepeatedPicture(async (bytes) => {
      const id = decoded.length;
      decoded.push([...bytes]);
      return {id, close: () => closed.push(id)};
    });
    const ids = [];
    for (const bytes of [[1, 2, 3], [1, 2, 3], [1, 2, 4], [1, 2, 4, 0], [1, 2, 4, 0]]) {
      ids.push((await picture.picture(new Uint8Array(bytes))).id);
    }
    // A real JPEG (3 x 2, made by the browser) through the real decoder.
    const canvas = new OffscreenCanvas(3, 2);
    canvas.getContext('2d').fillRect(0, 0, 3, 2);
    const jpeg = new Uint8Array(
        await (await canvas.convertToBlob({type: 'image/jpeg'})).arrayBuffer());
    const real = new m.RepeatedPicture();
    const first = await real.picture(jpeg);
    const again = await real.picture(jpeg.slice());
    return {ids, decoded: decoded.length, closed, same: first === again,
            size: [again.width, again.height]};)");
  EXPECT_EQ(r.at("ids"), (nlohmann::json{0, 0, 1, 2, 2}));
  EXPECT_EQ(r.at("decoded"), 3);
  EXPECT_EQ(r.at("closed"), (nlohmann::json{0, 1})) << "each replaced bitmap closed, once";
  EXPECT_TRUE(r.at("same").get<bool>()) << "the same bytes in another buffer: no new decode";
  EXPECT_EQ(r.at("size"), (nlohmann::json{3, 2}));
}

}  // namespace
}  // namespace ioct::devtools
