// SPDX-License-Identifier: Apache-2.0
#include "pocketsphinx_engine.h"

#include <pocketsphinx.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <regex>

namespace skr::asr {

namespace {

constexpr double kFramesPerSecond = 100;  // pocketsphinx's default frame rate

// pocketsphinx prints to stderr unless told otherwise; its errors come back as return codes.
// The reference decoder (grammar mode's rejection) runs the language model's first pass only
// (-fwdflat no -bestpath no): its score is all that is wanted, and it must cost little.
cmd_ln_t* makeConfig(const std::string& dir, bool reference) {
  const std::string hmm = dir + "/en-us";
  const std::string dict = dir + "/cmudict-en-us.dict";
  const std::string lm = dir + "/en-us.lm.bin";
  // -remove_silence no: our own VAD cut the utterance; pocketsphinx's would drop frames and
  // shift the word times.
  return cmd_ln_init(nullptr, ps_args(), TRUE, "-hmm", hmm.c_str(), "-dict", dict.c_str(), "-lm",
                     lm.c_str(), "-logfn", "/dev/null", "-remove_silence", "no", "-fwdflat",
                     reference ? "no" : "yes", "-bestpath", reference ? "no" : "yes", nullptr);
}

bool isFiller(const char* word) {
  return word == nullptr || word[0] == '<' || word[0] == '[' || word[0] == '+' || word[0] == '(' ||
         std::string_view(word) == "NULL";
}

std::string baseWord(const char* word) {  // "the(2)" -> "the"
  std::string w(word);
  if (const auto paren = w.find('('); paren != std::string::npos && paren > 0) w.resize(paren);
  return w;
}

}  // namespace

struct PocketsphinxEngine::Decoder {
  cmd_ln_t* config = nullptr;
  ps_decoder_t* ps = nullptr;
  bool in_utt = false;
  ~Decoder() {
    if (ps != nullptr) ps_free(ps);
    if (config != nullptr) cmd_ln_free_r(config);
  }
  // The frames of the utterance that fall in words (not silence or fillers), from its first frame.
  std::vector<bool> wordFrames() const {
    std::vector<bool> in_word;
    int origin = -1;
    for (ps_seg_t* s = ps_seg_iter(ps); s != nullptr; s = ps_seg_next(s)) {
      int sf = 0, ef = 0;
      ps_seg_frames(s, &sf, &ef);
      if (origin < 0) origin = sf;
      if (isFiller(ps_seg_word(s)) || ef < sf) continue;
      if (in_word.size() < static_cast<std::size_t>(ef - origin + 1))
        in_word.resize(ef - origin + 1);
      for (int f = sf; f <= ef; ++f) in_word[f - origin] = true;
    }
    return in_word;
  }
  // The sum of acoustic scores over the segments and the utterance's frames.
  double acousticScore(int& frames) const {
    double sum = 0;
    int first = -1, last = -1;
    for (ps_seg_t* s = ps_seg_iter(ps); s != nullptr; s = ps_seg_next(s)) {
      int32 ascr = 0, lscr = 0, lback = 0;
      (void)ps_seg_prob(s, &ascr, &lscr, &lback);
      sum += ascr;
      int sf = 0, ef = 0;
      ps_seg_frames(s, &sf, &ef);
      if (first < 0) first = sf;
      last = ef;
    }
    frames = first < 0 ? 0 : last - first + 1;
    return sum;
  }
};

PocketsphinxEngine::PocketsphinxEngine(PocketsphinxOptions options)
    : options_(std::move(options)) {}

PocketsphinxEngine::~PocketsphinxEngine() = default;

Result<std::unique_ptr<PocketsphinxEngine>> PocketsphinxEngine::create(
    const PocketsphinxOptions& options) {
  namespace fs = std::filesystem;
  for (const char* need : {"/en-us", "/en-us.lm.bin", "/cmudict-en-us.dict"}) {
    if (!fs::exists(options.model_dir + need)) {
      return makeError(Errc::not_found, "no pocketsphinx model " + options.model_dir + need +
                                            " (Debian: pocketsphinx-en-us)");
    }
  }
  std::unique_ptr<PocketsphinxEngine> engine(new PocketsphinxEngine(options));
  engine->main_ = std::make_unique<Decoder>();
  engine->main_->config = makeConfig(options.model_dir, false);
  if (engine->main_->config != nullptr) engine->main_->ps = ps_init(engine->main_->config);
  if (engine->main_->ps == nullptr) {
    return makeError(Errc::config_error, "pocketsphinx could not load " + options.model_dir);
  }
  // The language-model search made at init ("_default"; the name is not in 5prealpha's headers).
  if (const char* search = ps_get_search(engine->main_->ps); search != nullptr) {
    engine->dictation_search_ = search;
  }
  return engine;
}

Result<void> PocketsphinxEngine::setGrammar(const std::string& jsgf) {
  if (main_->in_utt) return makeError(Errc::invalid_argument, "an utterance is in progress");
  // A new search name each time: pocketsphinx keeps searches by name.
  const std::string name = "grammar" + std::to_string(++grammar_serial_);
  // The grammar search reads its beams from the decoder's configuration when it is made; the
  // language model's search keeps its own. The defaults (1e-48, word 7e-29) pruned the right
  // phrase of a short grammar for some voices ("move backward one meter" heard "look left").
  struct Beam {
    const char* name;
    double grammar, before = 0;
  } beams[] = {{"-beam", 1e-80}, {"-pbeam", 1e-80}, {"-wbeam", 1e-60}};
  for (auto& b : beams) {
    b.before = cmd_ln_float64_r(main_->config, b.name);
    cmd_ln_set_float64_r(main_->config, b.name, b.grammar);
  }
  const int compiled = ps_set_jsgf_string(main_->ps, name.c_str(), jsgf.c_str());
  for (const auto& b : beams) cmd_ln_set_float64_r(main_->config, b.name, b.before);
  if (compiled != 0) {
    return makeError(Errc::invalid_argument,
                     "the grammar does not compile (JSGF syntax, a public rule, every word in "
                     "the dictionary)");
  }
  if (ps_set_search(main_->ps, name.c_str()) != 0) {
    return makeError(Errc::internal, "pocketsphinx could not switch to the grammar");
  }
  if (grammar_serial_ > 1) {
    (void)ps_unset_search(main_->ps, ("grammar" + std::to_string(grammar_serial_ - 1)).c_str());
  }
  mode_ = Mode::grammar;
  if (options_.reject && !phone_) {
    auto phone = std::make_unique<Decoder>();
    phone->config = makeConfig(options_.model_dir, true);
    if (phone->config != nullptr) phone->ps = ps_init(phone->config);
    if (phone->ps != nullptr) phone_ = std::move(phone);  // else: no rejection, still works
  }
  return {};
}

Result<void> PocketsphinxEngine::setKeywords(const std::vector<std::string>& phrases) {
  // One rule whose alternatives are the phrases: lower case, letters, digits, apostrophes.
  std::string body;
  static const std::regex bad("[^a-z0-9' ]");
  for (const auto& p : phrases) {
    std::string phrase = p;
    std::transform(phrase.begin(), phrase.end(), phrase.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    phrase = std::regex_replace(phrase, bad, " ");
    if (phrase.find_first_not_of(' ') == std::string::npos) continue;
    if (!body.empty()) body += " | ";
    body += "(" + phrase + ")";
  }
  if (body.empty()) return makeError(Errc::invalid_argument, "no keyword phrases");
  return setGrammar("#JSGF V1.0;\ngrammar keywords;\npublic <keyword> = " + body + ";\n");
}

Result<void> PocketsphinxEngine::setDictation() {
  if (main_->in_utt) return makeError(Errc::invalid_argument, "an utterance is in progress");
  if (ps_set_search(main_->ps, dictation_search_.c_str()) != 0) {
    return makeError(Errc::internal, "pocketsphinx could not switch to dictation");
  }
  mode_ = Mode::dictation;
  return {};
}

Result<void> PocketsphinxEngine::start() {
  if (ps_start_utt(main_->ps) != 0) return makeError(Errc::internal, "ps_start_utt failed");
  main_->in_utt = true;
  phone_active_ = mode_ == Mode::grammar && phone_ && options_.reject;
  if (phone_active_) phone_active_ = ps_start_utt(phone_->ps) == 0;
  if (phone_) phone_->in_utt = phone_active_;
  return {};
}

Result<void> PocketsphinxEngine::feed(std::span<const std::int16_t> samples) {
  if (!main_->in_utt) return makeError(Errc::invalid_argument, "feed before start");
  if (ps_process_raw(main_->ps, samples.data(), samples.size(), FALSE, FALSE) < 0) {
    return makeError(Errc::internal, "ps_process_raw failed");
  }
  if (phone_active_) (void)ps_process_raw(phone_->ps, samples.data(), samples.size(), FALSE, FALSE);
  return {};
}

Result<AsrResult> PocketsphinxEngine::finish() {
  if (!main_->in_utt) return makeError(Errc::invalid_argument, "finish before start");
  main_->in_utt = false;
  if (ps_end_utt(main_->ps) != 0) return makeError(Errc::internal, "ps_end_utt failed");
  AsrResult result;
  int32 score = 0;
  const char* hyp = ps_get_hyp(main_->ps, &score);
  logmath_t* lmath = ps_get_logmath(main_->ps);
  // Word times: frames from the utterance's first frame (the decoder's frame counter runs on
  // across utterances; the first segment starts at the utterance's frame 0).
  int origin = -1;
  double posterior_sum = 0;
  int counted = 0;
  for (ps_seg_t* s = ps_seg_iter(main_->ps); s != nullptr; s = ps_seg_next(s)) {
    int sf = 0, ef = 0;
    ps_seg_frames(s, &sf, &ef);
    if (origin < 0) origin = sf;
    const char* word = ps_seg_word(s);
    if (isFiller(word)) continue;
    int32 ascr = 0, lscr = 0, lback = 0;
    const int32 post = ps_seg_prob(s, &ascr, &lscr, &lback);
    posterior_sum += std::clamp(logmath_exp(lmath, post), 0.0, 1.0);
    ++counted;
    result.words.push_back(
        {baseWord(word), (sf - origin) / kFramesPerSecond, (ef - origin + 1) / kFramesPerSecond});
  }
  for (const auto& w : result.words) result.text += (result.text.empty() ? "" : " ") + w.word;
  (void)hyp;
  // Dictation: the mean of the words' posteriors. Grammar: pocketsphinx gives no posteriors
  // for a grammar search, so the confidence comes from the two rejection measures below.
  result.confidence = counted > 0 ? posterior_sum / counted : 0;

  if (phone_active_) {
    phone_active_ = false;
    phone_->in_utt = false;
    if (ps_end_utt(phone_->ps) == 0 && !result.words.empty()) {
      int frames_g = 0, frames_p = 0;
      const double g = main_->acousticScore(frames_g);
      const double p = phone_->acousticScore(frames_p);
      result.scored = true;
      result.reject_score = frames_g > 0 ? (p - g) / frames_g : 0;
      const double t = options_.reject_threshold;
      // 0.5 at the threshold, 1 ten points below it, 0 ten above.
      result.confidence = std::clamp(0.5 + (t - result.reject_score) / 20, 0.0, 1.0);
      if (result.reject_score > t) result.rejected = true;
      // Speech the grammar could not place: the reference decoder hears words where the
      // grammar's best path has only silence or fillers (out-of-grammar speech ends up there).
      const auto speech = phone_->wordFrames();
      const auto placed = main_->wordFrames();
      int heard = 0, unplaced = 0;
      for (std::size_t f = 0; f < speech.size(); ++f) {
        if (!speech[f]) continue;
        ++heard;
        if (f >= placed.size() || !placed[f]) ++unplaced;
      }
      result.unplaced = heard > 0 ? static_cast<double>(unplaced) / heard : 0;
      const double m = options_.max_unplaced;
      if (result.unplaced > m) result.rejected = true;
      // Likewise 0.5 at the limit, 1 with every frame placed; the lower of the two.
      if (m > 0) result.confidence = std::min(result.confidence, 1 - result.unplaced / (2 * m));
      result.confidence = std::max(result.confidence, 0.0);
    }
  }
  if (mode_ == Mode::grammar && result.words.empty()) result.rejected = true;
  if (result.rejected) {
    result.text.clear();
    result.words.clear();
  }
  return result;
}

const char* modeName(Mode mode) noexcept {
  return mode == Mode::grammar ? "grammar" : "dictation";
}

}  // namespace skr::asr
