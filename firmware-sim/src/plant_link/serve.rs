//! The plant's side of the link: any [`Env`] served over a byte stream (a process's standard
//! input and output), so another program (the Python package's Gymnasium environment, a C
//! test, the trainer itself) can drive firmware-sim's plants.

use std::io::{BufRead, Write};

use super::messages::{self, Agent, FromPlant, Hello, StepReply, ToPlant};
use crate::env::Env;

/// The hello an [`Env`] sends under `name`.
///
/// ```
/// use firmware_sim::nav::NavEnv;
/// use firmware_sim::nav::scenario::Scenario;
/// use firmware_sim::plant_link::serve::hello;
/// let nav = NavEnv::new(&Scenario::builtin("nav-walls").unwrap()).unwrap();
/// let hello = hello("nav-walls", &nav);
/// assert_eq!(hello.agents[0].action_high, [0.25, 0.25]);
/// ```
pub fn hello(name: &str, env: &dyn Env) -> Hello {
    let (o, a) = (env.observation_space(), env.action_space());
    Hello {
        name: name.to_string(),
        agents: vec![Agent {
            name: "agent".into(),
            observation_low: o.low.clone(),
            observation_high: o.high.clone(),
            action_low: a.low.clone(),
            action_high: a.high.clone(),
        }],
    }
}

/// Answers requests from `input` on `output` until [`ToPlant::Close`] or the end of `input`.
/// A frame that does not decode, or an action of the wrong size, is answered with
/// [`FromPlant::Error`]; only a failure to read or write ends the loop with an error.
///
/// ```
/// use firmware_sim::nav::NavEnv;
/// use firmware_sim::nav::scenario::Scenario;
/// use firmware_sim::plant_link::messages::{decode, encode, FromPlant, ToPlant};
/// use firmware_sim::plant_link::serve::serve;
/// let mut nav = NavEnv::new(&Scenario::builtin("nav-open").unwrap()).unwrap();
/// let mut input = Vec::new();
/// for request in [ToPlant::Hello, ToPlant::Reset { seed: 3 }, ToPlant::Close] {
///     input.extend(encode(&request).unwrap());
/// }
/// let mut output = Vec::new();
/// serve("nav-open", &mut nav, &mut &input[..], &mut output).unwrap();
/// let mut frames = output.split_mut(|&b| b == 0).filter(|f| !f.is_empty());
/// let hello: FromPlant = decode(frames.next().unwrap()).unwrap();
/// assert!(matches!(hello, FromPlant::Hello(h) if h.name == "nav-open"));
/// let reset: FromPlant = decode(frames.next().unwrap()).unwrap();
/// assert!(matches!(reset, FromPlant::Reset { observation } if observation.len() == 2));
/// ```
pub fn serve(
    name: &str,
    env: &mut dyn Env,
    input: &mut impl BufRead,
    output: &mut impl Write,
) -> std::io::Result<()> {
    while let Some(frame) = messages::read_frame(input)? {
        let request = frame.and_then(|mut bytes| messages::decode::<ToPlant>(&mut bytes));
        let answer = match request {
            Ok(ToPlant::Close) => return Ok(()),
            Ok(request) => answer(name, env, request),
            Err(e) => FromPlant::Error {
                message: format!("firmware-sim could not read the request: {e}"),
            },
        };
        let frame = messages::encode(&answer)
            .map_err(|e| std::io::Error::other(format!("cannot frame the answer: {e}")))?;
        output.write_all(&frame)?;
        output.flush()?;
    }
    Ok(())
}

fn answer(name: &str, env: &mut dyn Env, request: ToPlant) -> FromPlant {
    match request {
        ToPlant::Hello => FromPlant::Hello(hello(name, env)),
        ToPlant::Reset { seed } => FromPlant::Reset {
            observation: env.reset(seed),
        },
        ToPlant::Step { action } if action.len() != env.action_space().dim() => FromPlant::Error {
            message: format!(
                "an action of {} values, expected {}",
                action.len(),
                env.action_space().dim()
            ),
        },
        ToPlant::Step { action } => {
            let step = env.step(&action);
            FromPlant::Step(StepReply {
                observation: step.observation,
                reward: step.reward,
                terminated: step.terminated,
                truncated: step.truncated,
                margin_touched: step.info.margin_touched,
                applied: step.info.applied,
                success: step.info.success,
            })
        }
        ToPlant::Close => unreachable!("answered by the loop"),
    }
}
