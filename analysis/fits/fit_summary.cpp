#include "analysis/fits/fit_summary.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "analysis/metrics/statistics.h"
#include "common/version.h"

namespace plumage::analysis {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kPi = std::numbers::pi;

// Huang's parameter table as analysis/models/huang2022.h states it (units, valid ranges); φ0 and φ1
// are limited only by φ0 < φ1 ≤ φ0 + 2π, which the JSON states beside them.
struct HuangRange {
    const char* unit;
    double min, max;
};
constexpr HuangRange kHuangRanges[kHuang2022ParameterCount] = {
    {"1", 1e-3, 1.0},                // b
    {"rad", -kInf, kInf},            // phi0
    {"rad", -kInf, kInf},            // phi1
    {"1", 0.0, kInf},                // H (> 0)
    {"um", 0.0, 50.0},               // d_um
    {"rad", 0.0, kPi / 4.0},         // theta_d (0, π/4]
    {"rad", -kPi / 2.0, kPi / 2.0},  // mu (−π/2, π/2)
};

std::string json_string(const std::string& s) {
    std::string out = "\"";
    for (const char c : s) {
        if (c == '"' || c == '\\') {
            out += '\\';
            out += c;
        } else if (static_cast<unsigned char>(c) < 0x20) {
            out += fmt::format("\\u{:04x}", static_cast<int>(c));
        } else {
            out += c;
        }
    }
    return out + "\"";
}

// Round-trip precision; JSON has no NaN or infinity: null.
std::string json_number(double v) { return std::isfinite(v) ? fmt::format("{:.17g}", v) : "null"; }

std::string json_bool(bool b) { return b ? "true" : "false"; }

// What both fits' results hold alike; `name(i)` names parameter i.
template <class Fit, class Name>
void fill_quality(const Fit& fit, Name name, FitSummary& s) {
    for (int i : fit.free_parameters) s.covariance_parameters.emplace_back(name(i));
    s.reduced_chi_square = fit.reduced_chi_square;
    s.degrees_of_freedom = fit.degrees_of_freedom;
    s.chi_square = fit.reduced_chi_square * fit.degrees_of_freedom;
    s.observations = fit.observations;
    s.residual_rms_per_sr = fit.residual_rms;
    s.converged = fit.converged;
    s.termination = fit.termination;
    if (fit.covariance_available) s.covariance = fit.covariance;
}

}  // namespace

std::vector<std::string> fit_warnings(const FitSummary& s) {
    std::vector<std::string> warnings;
    if (!s.converged)
        warnings.push_back(fmt::format("the fit did not converge ({})", s.termination));
    if (!s.provenance.standard_errors) {
        warnings.push_back(
            "the data give no standard errors: χ²/dof cannot say whether the model describes "
            "them, and σ comes from the scatter of the residuals");
    } else if (const double p = chi_square_p_value(s.chi_square, s.degrees_of_freedom);
               !(s.reduced_chi_square <= kFitWarningReducedChiSquare) ||
               !(p >= kFitWarningPValue)) {
        warnings.push_back(fmt::format(
            "χ²/dof = {:.3g} over {} degrees of freedom (p = {:.2g}): more than the data's σ "
            "allow; the model does not describe the data within their σ, or the fit stopped in "
            "a local minimum (the σ of the parameters are scaled by χ²/dof)",
            s.reduced_chi_square, s.degrees_of_freedom, p));
    }
    if (!s.undetermined.empty()) {
        warnings.push_back(fmt::format(
            "another minimum as good as this one (Δχ² ≤ 1) puts {} over 3σ away: the data do not "
            "decide between them",
            fmt::join(s.undetermined, ", ")));
    }
    if (s.covariance.size() == 0) {
        warnings.push_back(
            "no covariance: JᵀJ is singular at the optimum, so some combination of the free "
            "parameters is not determined by the data; fix one of them");
    }
    for (const FittedParameter& p : s.parameters) {
        if (p.fixed || !p.at_bound) continue;
        warnings.push_back(fmt::format(
            "{} = {:.6g} {} is on a bound of its valid range [{:g}, {:g}]: its σ is undefined, "
            "and the data may want a value the model does not allow",
            p.name, p.value, p.unit, p.min, p.max));
    }
    return warnings;
}

FitSummary summarise_fit(const HuangFitResult& fit, const HuangFitOptions& options,
                         FitProvenance provenance) {
    FitSummary s;
    s.model = "huang2022";
    s.reference =
        "Huang et al. 2022, elliptical barbule BSDF with thin-film interference (R + TRT), fitted "
        "to a scatterogram (analysis/fits/huang2022_fit.h)";
    for (int i = 0; i < kHuang2022ParameterCount; ++i) {
        const std::string name(kHuang2022ParameterNames[i]);
        const bool fixed =
            std::find(options.fixed.begin(), options.fixed.end(), name) != options.fixed.end();
        s.parameters.push_back({name, kHuangRanges[i].unit, fit.values[i], fit.standard_errors[i],
                                kHuangRanges[i].min, kHuangRanges[i].max, fixed, fit.at_bound[i]});
    }
    fill_quality(
        fit, [](int i) { return kHuang2022ParameterNames[i]; }, s);
    provenance.wavelengths_nm = fit.wavelengths_nm;
    s.provenance = std::move(provenance);
    s.local_fits = fit.local_fits;
    s.warnings = fit_warnings(s);
    return s;
}

FitSummary summarise_fit(const Filip2024FitResult& fit, const Filip2024FitOptions& options,
                         FitProvenance provenance) {
    FitSummary s;
    s.model = "filip2024";
    s.reference =
        "Filip, Maile and Vavra 2024, five-term feather BRDF, Eqs. 1-6 "
        "(analysis/models/filip2024.h), "
        "fitted by analysis/fits/filip2024_fit.h";
    for (int i = 0; i < kFilip2024ParameterCount; ++i) {
        const Filip2024ParameterInfo& info = kFilip2024ParameterTable[i];
        s.parameters.push_back({std::string(info.name), std::string(info.unit), fit.values[i],
                                fit.standard_errors[i], info.min, info.max, options.fixed[i],
                                fit.at_bound[i]});
    }
    fill_quality(
        fit, [](int i) { return kFilip2024ParameterTable[i].name; }, s);
    s.provenance = std::move(provenance);
    s.local_fits = fit.local_fits;
    for (int i : fit.undetermined) s.undetermined.emplace_back(kFilip2024ParameterTable[i].name);
    s.warnings = fit_warnings(s);
    return s;
}

std::string FitSummary::to_json() const {
    std::string j = "{\n  \"format\": \"plumage fit\",\n  \"format_version\": 1,\n";
    j += fmt::format("  \"plumage_version\": {},\n  \"model\": {},\n  \"reference\": {},\n",
                     json_string(kVersion), json_string(model), json_string(reference));
    j += "  \"parameters\": {\n";
    for (std::size_t i = 0; i < parameters.size(); ++i) {
        const FittedParameter& p = parameters[i];
        j += fmt::format(
            "    {}: {{\"value\": {}, \"sigma\": {}, \"unit\": {}, \"min\": {}, \"max\": {}, "
            "\"fixed\": {}, \"at_bound\": {}}}{}\n",
            json_string(p.name), json_number(p.value), json_number(p.sigma), json_string(p.unit),
            json_number(p.min), json_number(p.max), json_bool(p.fixed), json_bool(p.at_bound),
            i + 1 < parameters.size() ? "," : "");
    }
    j += "  },\n";
    if (model == "huang2022") {
        j += "  \"constraints\": [\"phi0 < phi1 <= phi0 + 2 pi\", \"H > 0\", \"theta_d > 0\"],\n";
    }
    j += fmt::format(
        "  \"fit\": {{\"chi_square\": {}, \"degrees_of_freedom\": {}, \"reduced_chi_square\": {}, "
        "\"observations\": {}, \"residual_rms_per_sr\": {}, \"converged\": {}, \"termination\": "
        "{}, "
        "\"local_fits\": {}, \"sigma_scaled_by_reduced_chi_square\": true}},\n",
        json_number(chi_square), degrees_of_freedom, json_number(reduced_chi_square), observations,
        json_number(residual_rms_per_sr), json_bool(converged), json_string(termination),
        local_fits);
    j += "  \"warnings\": [";
    for (std::size_t i = 0; i < warnings.size(); ++i)
        j += (i ? ", " : "") + json_string(warnings[i]);
    j += "],\n";
    j += "  \"covariance\": ";
    if (covariance.size() == 0) {
        j += "null,\n";
    } else {
        j += "{\"parameters\": [";
        for (std::size_t i = 0; i < covariance_parameters.size(); ++i)
            j += (i ? ", " : "") + json_string(covariance_parameters[i]);
        j += "],\n    \"matrix\": [";
        for (Eigen::Index r = 0; r < covariance.rows(); ++r) {
            j += r ? ",\n      [" : "\n      [";
            for (Eigen::Index c = 0; c < covariance.cols(); ++c)
                j += (c ? ", " : "") + json_number(covariance(r, c));
            j += "]";
        }
        j += "]},\n";
    }
    const FitProvenance& d = provenance;
    j += fmt::format(
        "  \"data\": {{\"file\": {}, \"format\": {}, \"standard_errors\": {}, "
        "\"left_out\": {}, \"wavelengths_nm\": [",
        json_string(d.data_file), json_string(d.data_format), json_bool(d.standard_errors),
        d.left_out);
    for (std::size_t i = 0; i < d.wavelengths_nm.size(); ++i)
        j += (i ? ", " : "") + json_number(d.wavelengths_nm[i]);
    j += "]}\n}\n";
    return j;
}

}  // namespace plumage::analysis
