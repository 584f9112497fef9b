#include "train/mlp.hpp"

#include <cmath>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "src/core/config_json.hpp"
#include "src/core/limits.hpp"

namespace atacom {

std::string activation_name(Activation a) {
  switch (a) {
    case Activation::Relu: return "relu";
    case Activation::Tanh: return "tanh";
    case Activation::Sigmoid: return "sigmoid";
    case Activation::Softplus: return "softplus";
  }
  return "relu";
}

Activation parse_activation(const std::string& s) {
  if (s == "relu") return Activation::Relu;
  if (s == "tanh") return Activation::Tanh;
  if (s == "sigmoid") return Activation::Sigmoid;
  if (s == "softplus") return Activation::Softplus;
  throw std::invalid_argument("unknown activation '" + printable_text(s) + "' (known: relu, tanh, sigmoid, softplus)");
}

double activation_gain(Activation a) {
  switch (a) {
    case Activation::Relu: return std::sqrt(2.0);
    case Activation::Tanh: return 5.0 / 3.0;
    default: return 1.0;
  }
}

MlpConfig default_mlp_config() { return MlpConfig{}; }

void to_json(nlohmann::json& j, const MlpConfig& c) {
  j = nlohmann::json{{"hidden", c.hidden}, {"activation", activation_name(c.activation)}};
}

MlpConfig read_mlp_config(const nlohmann::json& j, const std::string& section) {
  ConfigReader r(j, section);
  MlpConfig c = default_mlp_config();
  // Hidden layer widths: at least one layer (an empty list is a linear map, which SAC cannot learn with).
  r.get("hidden", c.hidden, range::closed(1, limits::kMaxMlpWidth), 1, size_t(limits::kMaxMlpLayers));
  std::string act = activation_name(c.activation);
  r.get("activation", act);
  c.activation = parse_activation(act);
  r.finish();
  return c;
}

void from_json(const nlohmann::json& j, MlpConfig& c) { c = read_mlp_config(j, "mlp"); }

template <class T>
Mlp<T>::Mlp(int in, int out, const MlpConfig& cfg, int ensemble)
    : in_(in), out_(out), ensemble_(ensemble), act_(cfg.activation) {
  if (in < 1 || out < 1 || ensemble < 1) throw std::invalid_argument("Mlp: sizes must be positive");
  size_t off = 0;
  int prev = in;
  std::vector<int> widths = cfg.hidden;
  widths.push_back(out);
  for (int w : widths) {
    Layer l{prev, w, off, 0};
    off += size_t(ensemble) * size_t(prev) * size_t(w);
    l.b = off;
    off += size_t(ensemble) * size_t(w);
    layers_.push_back(l);
    prev = w;
  }
  if (off > size_t(limits::kMaxMlpParams))
    throw std::invalid_argument("network of " + std::to_string(off) + " parameters (" + std::to_string(in) + " inputs, " +
                                std::to_string(out) + " outputs, x" + std::to_string(ensemble) +
                                ") is larger than the limit of 2^27: reduce the hidden widths");
  params_.assign(off, T(0));
  grads_.assign(off, T(0));
}

template <class T>
void Mlp<T>::init(Rng& rng) {
  const double gain = activation_gain(act_);
  for (const Layer& l : layers_) {
    const double bound = gain * std::sqrt(6.0 / double(l.in + l.out));
    const size_t nw = size_t(ensemble_) * size_t(l.in) * size_t(l.out);
    for (size_t i = 0; i < nw; ++i) params_[l.w + i] = static_cast<T>(rng.uniform(-bound, bound));
    for (size_t i = 0; i < size_t(ensemble_) * size_t(l.out); ++i) params_[l.b + i] = T(0);
  }
}

template <class T>
typename Tape<T>::Id Mlp<T>::forward(Tape<T>& tape, typename Tape<T>::Id x, bool param_grads,
                                     typename Tape<T>::GradMode mode) {
  typename Tape<T>::Id h = x;
  for (size_t li = 0; li < layers_.size(); ++li) {
    const Layer& l = layers_[li];
    T* gw = param_grads ? grads_.data() + l.w : nullptr;
    T* gb = param_grads ? grads_.data() + l.b : nullptr;
    const auto W = tape.leaf(params_.data() + l.w, gw, ensemble_ * l.in, l.out, mode);
    const auto b = tape.leaf(params_.data() + l.b, gb, 1, ensemble_ * l.out, mode);
    const bool hidden = li + 1 < layers_.size();
    h = tape.linear(h, W, b, ensemble_, hidden && act_ == Activation::Relu);
    if (hidden) {
      switch (act_) {
        case Activation::Relu: break;  // fused into the linear op
        case Activation::Tanh: h = tape.tanh(h); break;
        case Activation::Sigmoid: h = tape.sigmoid(h); break;
        case Activation::Softplus: h = tape.softplus(h); break;
      }
    }
  }
  return h;
}

template <class T>
void Mlp<T>::zero_grad() {
  std::fill(grads_.begin(), grads_.end(), T(0));
}

template <class T>
double Mlp<T>::forward_flops_per_sample() const {
  double f = 0;
  for (const Layer& l : layers_) f += 2.0 * l.in * l.out * ensemble_;
  return f;
}

template class Mlp<float>;
template class Mlp<double>;

}  // namespace atacom
