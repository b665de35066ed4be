// placeholder: reports, results database and exports land here (issue 6).
namespace stend::reporting {}
